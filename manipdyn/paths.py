"""Where the bundled models live: the repository's urdf/ folder, or <prefix>/share/manipdyn/urdf once installed."""
from __future__ import annotations

import sys
from pathlib import Path


def bundled_dir() -> Path:
    """Folder of the chapter's URDF models (aau_arm, spm, fourbar)."""
    repo = Path(__file__).resolve().parent.parent / "urdf"
    return repo if repo.is_dir() else Path(sys.prefix) / "share" / "manipdyn" / "urdf"

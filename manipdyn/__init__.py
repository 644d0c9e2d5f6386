"""manipdyn: manipulator dynamics you can read and trust."""
from __future__ import annotations

from .errors import (DivergenceError, InputError, ManipdynError, ModelError, SingularError,
                     URDFError)

__version__ = "0.1.0"

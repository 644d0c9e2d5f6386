"""Speed against error, side by side with Pinocchio (imported on demand, like validation)."""
from .report import run

__all__ = ["run"]

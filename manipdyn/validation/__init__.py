"""Validation against Pinocchio (the referee). Imported on demand: ``import manipdyn`` never loads it."""
from .compare import Report, format_report, random_states, validate
from .measure import error
from .mimic import validate_mimic
from .zoo import arm_paths, floating_paths, robots_dir

__all__ = ["Report", "error", "format_report", "random_states", "validate", "validate_mimic", "arm_paths", "floating_paths", "robots_dir"]

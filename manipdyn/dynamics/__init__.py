"""Tree dynamics: the kernels (rnea, crba, aba, derivatives, kinematics) and their Python entry points."""
from .derivatives import aba_derivatives, rnea_derivatives

__all__ = ["aba_derivatives", "rnea_derivatives"]

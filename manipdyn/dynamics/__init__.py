"""Tree dynamics: the kernels (rnea, crba, aba, derivatives, regressor, kinematics) and their Python entry points."""
from .derivatives import aba_derivatives, rnea_derivatives
from .regressor import dynamic_parameters, joint_torque_regressor, model_with_parameters

__all__ = ["aba_derivatives", "rnea_derivatives", "dynamic_parameters", "joint_torque_regressor",
           "model_with_parameters"]

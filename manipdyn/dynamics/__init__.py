"""Tree dynamics: Newton–Euler, CRBA, ABA, Lagrange, kinematics, energies, the joint-torque regressor."""
from .regressor import dynamic_parameters, joint_torque_regressor, model_with_parameters

__all__ = ["dynamic_parameters", "joint_torque_regressor", "model_with_parameters"]

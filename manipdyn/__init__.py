"""manipdyn: manipulator dynamics you can read and trust.

Public API (names follow Pinocchio's where the meaning is the same). Every dynamics function takes one
state — q (nq,), q̇, q̈, τ (nv,) — or a batch (N, nq), (N, nv), and returns the matching shape; nq = nv but
for a free-flyer root (``load_urdf(path, root_joint="free_flyer")``, or an MJCF free joint), whose q moves by ``integrate``.
``load_mjcf`` reads MuJoCo's MJCF, ``load_model`` either format by the file's root element.
A tree with <mimic> joints honoured (``load_urdf(path, mimic=True)`` -> MimicModel) goes to the calls listed in
``manipdyn.dynamics.mimic.TAKES_MIMIC``, in its independent coordinates; every other call refuses it.
Pinocchio is never imported here.
"""
from __future__ import annotations

from . import compile_notice  # noqa: F401  (a call that compiles says so once)
from .configuration import difference, integrate, neutral, normalize, random_configuration
from .dynamics.aba import aba, forward_dynamics
from .dynamics.derivatives import aba_derivatives, rnea_derivatives
from .dynamics.energy import kinetic_energy, potential_energy
from .dynamics.kinematics import frame_jacobian, frame_jacobian_dot, frame_placement
from .dynamics.coriolis import coriolis_matrix
from .dynamics.crba import mass_matrix
from .dynamics.rnea import gravity_torques, nonlinear_effects, rnea, rnea_terms
from .dynamics.regressor import dynamic_parameters, joint_torque_regressor, model_with_parameters
from .errors import (ConstraintError, DivergenceError, FloatingBaseWarning, InertiaWarning, InputError,
                     ManipdynError, MJCFError, ModelError, NumericalError, QuirkWarning, SingularError, URDFError)
from .io.urdf import load_urdf, load_urdf_string
from .io.mjcf_read import load_mjcf, load_mjcf_string
from .io.load import load_model
from .joints import BALL, FREEFLYER, HELICAL, PLANAR, PRISMATIC, REVOLUTE
from .model import Frame, MimicModel, Model, with_joint_dynamics
from .quirks import Quirk
from .reduce import reduce
from .constraints import (assemble, complete_state, constrained_forward_dynamics,  # noqa: E402
                          constrained_inverse_dynamics, project)
from .simulation import SimResult, simulate

__version__ = "0.1.0"


def dh_to_urdf(*args, **kwargs):
    """D-H table -> URDF text; see manipdyn.io.dh.dh_to_urdf."""
    from .io.dh import dh_to_urdf as _dh_to_urdf
    return _dh_to_urdf(*args, **kwargs)


__all__ = ["constrained_forward_dynamics", "constrained_inverse_dynamics", "project", "assemble",
           "complete_state", "simulate", "SimResult", "kinetic_energy", "potential_energy", "reduce", "rnea", "rnea_terms",
           "nonlinear_effects", "aba", "forward_dynamics", "rnea_derivatives", "aba_derivatives", "mass_matrix", "coriolis_matrix",
           "gravity_torques", "frame_placement", "frame_jacobian", "frame_jacobian_dot", "load_urdf", "load_urdf_string", "load_mjcf", "load_mjcf_string", "load_model", "MJCFError", "dh_to_urdf", "Model", "Frame",
           "MimicModel", "Quirk", "QuirkWarning",
           "REVOLUTE", "PRISMATIC", "ManipdynError", "URDFError", "ModelError", "InputError",
           "SingularError", "DivergenceError", "ConstraintError", "NumericalError", "InertiaWarning",
           "FloatingBaseWarning", "FREEFLYER", "BALL", "HELICAL", "PLANAR", "neutral", "integrate", "difference", "random_configuration",
           "normalize", "joint_torque_regressor", "dynamic_parameters", "model_with_parameters",
           "with_joint_dynamics"]

"""The one error hierarchy of manipdyn: every message names the file, link, joint or array at fault."""
from __future__ import annotations


class ManipdynError(Exception):
    """Base class of every error manipdyn raises on purpose."""


class URDFError(ManipdynError, ValueError):
    """The URDF (or D-H table) cannot be turned into a model: names the file and the element at fault."""


class MJCFError(ManipdynError, ValueError):
    """The MJCF file cannot be turned into a model (manipdyn.io.mjcf_read): names the file, the element (body,
    joint, geom, include) and the attribute or feature at fault, or the feature not supported yet."""


class ModelError(ManipdynError, ValueError):
    """A model is inconsistent (bad inertia, unknown name, ...): names the link or joint at fault."""


class InputError(ManipdynError, ValueError):
    """An argument has the wrong shape, a non-finite value or an unknown name: names the array at fault."""


class SingularError(ManipdynError, ArithmeticError):
    """A matrix that must be inverted is singular: names the joints or closures involved."""


class NumericalError(ManipdynError, ArithmeticError):
    """A computation produced a non-finite value from finite inputs: names the call and the first offending
    row and joint or link (an intermediate overflowed; the inputs or the model are out of scale)."""


class ConstraintError(ManipdynError, ValueError):
    """Loop closures cannot be satisfied (assembly fails, a state violates them): names the closure."""


class DivergenceError(ManipdynError, ArithmeticError):
    """A simulation produced a non-finite state: names the time at which it happened."""


class MissingExtraError(ManipdynError, ImportError):
    """An optional package is not installed: names the feature that needs it and the pip command of the
    manipdyn extra that brings it (manipdyn.extras.require). ``import manipdyn`` and the algorithms need none."""


class QuirkWarning(UserWarning):
    """Something the URDF loader noticed (Model.quirks): one warning per kind, naming every link or joint."""


class InertiaWarning(QuirkWarning):
    """A link's inertia is physically inconsistent (triangle inequality) but loadable."""


class GeometryWarning(UserWarning):
    """A visual element is skipped (bad numbers, unknown format, or a mesh file outside the allowed roots)."""


class FloatingBaseWarning(QuirkWarning):
    """A URDF loaded with a fixed base has a root body that carries mass and the tree's shape of a free body
    (legs, a heavy body with a hanging appendage, or no joint): load it with root_joint="free_flyer"."""

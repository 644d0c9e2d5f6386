"""Closed chains: loop closures (Φ, Φ_q, Φ̇_q q̇), Lagrange's equations of the 1st kind, assembly."""
from .assembly import Assembly, assemble, complete_state, project
from .closures import closure_terms, independent_rows, row_labels
from .dynamics import (RankReport, actuation_status, constrained_forward_dynamics,
                       constrained_inverse_dynamics, rank_report)

__all__ = ["Assembly", "assemble", "complete_state", "project", "closure_terms", "independent_rows",
           "row_labels", "RankReport", "actuation_status", "constrained_forward_dynamics",
           "constrained_inverse_dynamics", "rank_report"]

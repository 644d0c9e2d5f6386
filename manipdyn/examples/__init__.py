"""The chapter's two examples: the AAU 5-dof arm (Example I) and the co-axial SPM (Example II)."""

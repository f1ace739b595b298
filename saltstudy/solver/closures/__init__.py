"""Subgrid-scale closures: Deardorff's TKE (the paper's) and dynamic Smagorinsky, chosen by ``closure.make_closure``."""

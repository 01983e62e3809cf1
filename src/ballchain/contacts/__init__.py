"""The contact laws (``registry``: their names and parameters; one module each: its
kernels).  See ``registry`` for what a law is and how a method honours it."""

from .registry import LAWS, all_params, law_of, law_param_help

__all__ = ["LAWS", "all_params", "law_of", "law_param_help"]

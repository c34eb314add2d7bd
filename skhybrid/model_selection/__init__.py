"""Interpolative and extrapolative test sets, and convex hull membership."""

from skhybrid.model_selection._hull import in_convex_hull

__all__ = ["in_convex_hull"]

"""Seeing the mechanism: drawings (``crankfmu draw``) and animations (``crankfmu animate``) read
from the mechanism file alone, the velocity plan, and the label placement and overlap check every
figure uses.

``sketch`` (the drawing's topology and positions, numpy only) -> ``draw`` (matplotlib artists,
overlays) -> ``animate`` (frames, GIF/MP4); ``labels`` serves them and ``velocity_plan``. Nothing
here runs in an FMU.
"""

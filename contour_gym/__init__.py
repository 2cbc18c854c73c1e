"""contour-gym: Gymnasium environments for multi-axis CNC servo contouring.

Importing this package never imports torch.
"""

from __future__ import annotations

__version__ = "0.1.0"

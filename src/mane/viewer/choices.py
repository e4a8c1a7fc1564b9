"""What the viewer's panel offers and how wide it is (the window and the panel both read these)."""
from __future__ import annotations

MOTIONS = ("none", "nod", "shake", "turn")
AA_CHOICES = ("none", "coverage", "msaa2", "msaa4", "msaa8", "ssaa2", "msaa4+ssaa2")
PANEL_WIDTH = 380    # pixels

"""The browser GUI (viser): a viewer of any running env, and sliders that drive a debug task by hand.

Imported only when a script opens the viewer: headless runs do not load it.
"""

from agile.gui.controls import ActionSliders, limb_of
from agile.gui.viewer import LOCAL_HOST, BrowserViewer

__all__ = ["ActionSliders", "BrowserViewer", "LOCAL_HOST", "limb_of"]

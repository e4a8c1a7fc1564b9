"""The hair through an order-independent transparency method (``RenderSettings.oit``), after
the opaque head, in place of HairPass: the method's fill draws and its composite over the HDR
target. ``capture_under = True`` keeps a copy of the HDR colour before the hair
(``frame.targets["oit_under"]``, float32 RGBA, bottom row first): the validation's reference
composites over it. Where the renderer draws the hair with compute shaders
(``settings.rasterizer``), the A-buffer, K-buffer, DBK-buffer and ShortCut come in their compute
form (``mane.render.oit.compute``): ``stats()["rasterizer"]`` says which ran."""
from __future__ import annotations

import numpy as np

from .base import Frame, Pass


class OitPass(Pass):
    name = "oit"
    reads = ("strands", "shadow_map", "dom", "hdr")
    writes = ("hdr",)

    def __init__(self, renderer):
        super().__init__(renderer)
        self.method = None
        self.capture_under = False

    def enabled(self, frame: Frame) -> bool:
        return self.renderer.strands is not None and self.renderer.settings.oit != "none"

    def current(self):
        """The method object of the current settings (made, or remade when the name changed)."""
        from ..oit import make_method
        from ..oit.compute import uses_compute

        name = self.renderer.settings.oit
        if self.method is not None and (self.method.name != name or
                                        getattr(self.method, "compute", False) != uses_compute(self.renderer)):
            self.method.release()
            self.method = None
        if self.method is None and name != "none":
            self.method = make_method(name, self.renderer)
        return self.method

    def run(self, frame: Frame) -> None:
        r = self.renderer
        m = self.current()
        if self.capture_under:
            w, h = r.settings.render_size
            tex = r.hdr_target().color
            frame.targets["oit_under"] = np.frombuffer(tex.read(), np.float16).reshape(h, w, 4).astype(np.float32)
        m.run(frame)
        frame.targets["oit"] = m

    def stats(self) -> dict:
        s = self.renderer.settings
        if s.oit == "none":
            return {"oit": "none", "oit_bytes": 0}
        m = self.current()
        return m.stats()   # "rasterizer": the method's own (hardware methods keep the renderer's)

    def release(self) -> None:
        if self.method is not None:
            self.method.release()
            self.method = None

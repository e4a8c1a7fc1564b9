"""Show a rendered image in a window: a plain framebuffer copy when the sizes match, else a
full-screen triangle that samples the image with linear filtering (shaders: present.vert/.frag)."""
from __future__ import annotations

from pathlib import Path

from ..gpu.glsl import program
from ..gpu.uniforms import write_uniform

HERE = Path(__file__).resolve().parent


class Presenter:
    """``Presenter(ctx).show(src_fbo, src_texture, dst_fbo, bind=window.use)``."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.prog = program(ctx, vertex=HERE / "present.vert", fragment=HERE / "present.frag", cache=False)
        self.vao = ctx.vertex_array(self.prog, [])

    def show(self, src_fbo, src_texture, dst_fbo, bind=None) -> None:
        """Put ``src_fbo`` (whose colour is ``src_texture``) on ``dst_fbo``; ``bind`` binds the
        destination (default ``dst_fbo.use``), which is left bound."""
        ctx = self.ctx
        bind = bind if bind is not None else dst_fbo.use
        if tuple(src_fbo.size) == tuple(dst_fbo.size):   # a plain copy (0.9 ms on llvmpipe, 1.5 drawn)
            ctx.copy_framebuffer(dst_fbo, src_fbo)
            bind()
            return
        bind()
        ctx.disable(ctx.DEPTH_TEST)
        ctx.disable(ctx.BLEND)
        src_texture.filter = (ctx.LINEAR, ctx.LINEAR)
        src_texture.use(0)
        write_uniform(self.prog["u_image"], 0)
        self.vao.render(ctx.TRIANGLES, vertices=3)

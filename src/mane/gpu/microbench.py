"""Small GPU kernels that ``mane bench`` and ``mane doctor`` run: the GL side of the micro-benchmarks
(timing, rows and reports stay in ``mane.bench``).

    k = CopyKernel(ctx, nbytes)       # limits_copy.comp: a streaming copy between two buffers
    k.run(); k.copied_ok(); k.release()
    r = RasterStrips(ctx, (W, H), msaa, strips, per_row=.., rows=.., segments=.., seg_px=.., width_px=..)
    r.draw(); r.samples_passed(); r.release()     # limits_raster.vert / .frag
    a = AtomicKernel(ctx, words, bits, pattern, threads, ops)   # limits_atomic.comp
    a.run(); a.release()
    p = GpuPreload(ctx)               # a serial compute job that keeps the GPU busy
    p.dispatch(iterations); p.release()
    selftest(ctx)                     # mane doctor's compute-shader check

The shaders sit beside this file; ``mane.bench.limits`` describes what each measures.
"""
from __future__ import annotations

import math
from pathlib import Path

from .buffers import check_allocation
from .glsl import compute_shader, program
from .bindings import B_DST, B_SRC, B_WORDS

HERE = Path(__file__).resolve().parent
LOCAL = 256
MAX_GROUPS_X = 65535


def _groups(n: int) -> tuple[int, int]:
    g = max(1, math.ceil(n / LOCAL))
    gx = min(g, MAX_GROUPS_X)
    return gx, math.ceil(g / gx)


def _buffer(ctx, nbytes: int, what: str, fill: int | None = None):
    check_allocation(ctx, nbytes, what)
    buf = ctx.buffer(reserve=nbytes)
    if fill is not None:
        buf.clear(chunk=bytes([fill]) * 4)
    return buf


def max_samples(ctx) -> int:
    """GL_MAX_SAMPLES (4 where the driver does not say)."""
    return int(ctx.info.get("GL_MAX_SAMPLES", 4) or 4)


class CopyKernel:
    """``limits_copy.comp``: copies ``nbytes`` (a multiple of 16) from one buffer to another, one
    uvec4 a thread. The source's last 64 bytes are set, so ``copied_ok()`` can check the copy.
    Raises ``GPUMemoryError`` where the two buffers do not fit."""

    def __init__(self, ctx, nbytes: int):
        self.nbytes = int(nbytes)
        self.count = self.nbytes // 16           # uvec4s, one a thread
        self.src = _buffer(ctx, self.nbytes, "the copy benchmark's source")
        self.dst = None
        try:
            self.src.write(b"\x5a" * 64, offset=self.nbytes - 64)   # checked in the copy afterwards
            self.dst = _buffer(ctx, self.nbytes, "the copy benchmark's destination")
            self.shader = compute_shader(ctx, HERE / "limits_copy.comp")
            self.shader["u_count"] = self.count
        except Exception:
            self.release()
            raise
        self.groups = _groups(self.count)

    def run(self) -> None:
        self.src.bind_to_storage_buffer(B_SRC)
        self.dst.bind_to_storage_buffer(B_DST)
        self.shader.run(*self.groups)

    def copied_ok(self) -> bool:
        """Whether the destination's last 64 bytes are the source's."""
        return bytes(self.dst.read(size=64, offset=self.nbytes - 64)) == b"\x5a" * 64

    def release(self) -> None:
        for buf in (self.src, self.dst):
            if buf is not None:
                buf.release()
        self.src = self.dst = None


class RasterStrips:
    """``limits_raster.vert`` / ``.frag``: ``strips`` instanced triangle strips of ``segments``
    quads ``seg_px`` x ``width_px`` pixels, vertex pulled, tiling a ``size`` target pixel-aligned
    (``per_row`` strips a row, ``rows`` rows a layer; instances beyond a layer start again at the
    top), trivial fragment shader, no depth test, no blending, into an RGBA16F target with
    ``msaa`` samples (a renderbuffer; a texture for 1). Building it binds the target and clears
    it; ``release()`` gives the context its framebuffer back."""

    def __init__(self, ctx, size, msaa: int, strips: int, *, per_row: int, rows: int,
                 segments: int, seg_px: float, width_px: float):
        W, H = (int(v) for v in size)
        self.ctx = ctx
        self.strips = int(strips)
        self.vertices = 2 * (int(segments) + 1)
        prog = program(ctx, vertex=HERE / "limits_raster.vert", fragment=HERE / "limits_raster.frag",
                       defines={"SEGMENTS": int(segments)})
        prog["u_size"] = (float(W), float(H))
        prog["u_strips_per_row"] = int(per_row)
        prog["u_rows"] = int(rows)
        prog["u_seg_px"] = float(seg_px)
        prog["u_width_px"] = float(width_px)
        self.vao = ctx.vertex_array(prog, [])
        if msaa > 1:
            self.color = ctx.renderbuffer((W, H), 4, samples=msaa, dtype="f2")
        else:
            self.color = ctx.texture((W, H), 4, dtype="f2")
        self.fbo = ctx.framebuffer([self.color])
        self.previous = ctx.fbo     # given back before fbo is released (a Renderer keeps ctx.fbo)
        try:
            self.fbo.use()
            self.fbo.clear(0.0, 0.0, 0.0, 0.0)
        except Exception:
            self.release()
            raise

    def draw(self) -> None:
        ctx = self.ctx
        self.fbo.use()
        ctx.disable(ctx.DEPTH_TEST | ctx.BLEND | ctx.CULL_FACE)
        self.vao.render(ctx.TRIANGLE_STRIP, vertices=self.vertices, instances=self.strips)

    def samples_passed(self) -> int:
        """One more draw inside a ``GL_SAMPLES_PASSED`` query: the samples it wrote (raises where
        there is no occlusion query)."""
        q = self.ctx.query(samples=True)
        with q:
            self.draw()
        return int(q.samples)

    def release(self) -> None:
        if self.previous is not None:
            self.previous.use()
        else:              # headless: none bound before (as Renderer.release does)
            self.ctx.fbo = None
        self.fbo.release()
        self.color.release()
        self.vao.release()


class AtomicKernel:
    """``limits_atomic.comp``: ``threads`` threads x ``ops`` atomicMin on ``bits``-bit words (32, or
    64 with GL_NV_shader_atomic_int64) of a ``words``-word buffer filled with ones; ``pattern`` 0:
    each at a random word, 1: each thread at consecutive words from a random one. Every
    ``run()`` takes a new seed."""

    def __init__(self, ctx, words: int, bits: int, pattern: int, threads: int, ops: int):
        self.buf = _buffer(ctx, words * bits // 8, "the atomics benchmark's buffer", fill=0xFF)
        try:
            self.shader = compute_shader(ctx, HERE / "limits_atomic.comp",
                                         {"ATOMIC64": int(bits == 64), "PATTERN": pattern})
            self.shader["u_words"] = words
            self.shader["u_threads"] = threads
            self.shader["u_ops"] = ops
        except Exception:
            self.release()
            raise
        self.groups = _groups(threads)
        self.seed = 0

    def run(self) -> None:
        self.seed += 1
        self.shader["u_seed"] = (self.seed * 2654435761) & 0xFFFFFFFF
        self.buf.bind_to_storage_buffer(B_WORDS)
        self.shader.run(*self.groups)

    def release(self) -> None:
        if self.buf is not None:
            self.buf.release()
        self.buf = None


# --------------------------------------------------------------------------- a busy GPU
BUSY_COMP = """#version 430
layout(local_size_x = 1) in;
layout(std430, binding = BINDING) buffer BenchSink { float bench_sink[]; };
uniform int u_iterations;
void main() {
    float x = 1.0 + 1e-3 * float(gl_WorkGroupID.x);
    for (int i = 0; i < u_iterations; ++i)
        x = fract(x * 1.0000013 + 0.1234567);
    bench_sink[gl_WorkGroupID.x] = x;
}
"""


class GpuPreload:
    """Keeps the GPU busy (one serial compute invocation) while the CPU issues a frame.

    With the GPU behind, the frame's commands are all queued before it starts on them, so a
    timestamp pair around the frame reads the GPU's own time, without the idle gaps that
    Python's issuing between passes leaves otherwise. The sink buffer sits at the last SSBO
    binding, out of the renderer's way. (``mane.bench.render_bench`` calibrates it.)"""

    def __init__(self, ctx):
        from .capabilities import gl_function

        self.ctx = ctx
        self.binding = max(7, int(ctx.info.get("GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS", 8) or 8) - 1)
        self.shader = ctx.compute_shader(BUSY_COMP.replace("BINDING", str(self.binding)))
        self.sink = ctx.buffer(reserve=16)
        self._flush = gl_function(ctx, "glFlush", None)

    def dispatch(self, iterations: int) -> None:
        self.sink.bind_to_storage_buffer(self.binding)
        self.shader["u_iterations"] = int(min(max(1, iterations), 2**31 - 1))
        self.shader.run(1)
        if self._flush is not None:
            self._flush()   # start it now, while the CPU issues the frame

    def release(self) -> None:
        for o in (self.shader, self.sink):
            try:
                o.release()
            except Exception:
                pass


# --------------------------------------------------------------------------- mane doctor
def selftest(ctx) -> dict:
    """Compile common.glsl into a compute shader, run it, check the numbers: {"ok", "detail"}."""
    import tempfile
    import time

    import numpy as np

    from .glsl import SHARED_SHADER_DIR, _compile, load_source

    src_path = SHARED_SHADER_DIR / "common.glsl"
    t0 = time.perf_counter()
    try:
        with tempfile.TemporaryDirectory() as tmp:
            p = Path(tmp) / "doctor_selftest.comp"
            p.write_text(
                '#version 430 core\n#include "common.glsl"\n'
                "layout(local_size_x = 64) in;\n"
                "layout(std430, binding = 0) buffer Data { float v[]; };\n"
                "void main() { uint i = gl_GlobalInvocationID.x;\n"
                "  v[i] = v[i] * 2.0 + PI + rand01(i, 7u) * 0.0; }\n")
            src = load_source(p)
            shader = _compile(ctx, "compute shader", {"compute": src}, lambda: ctx.compute_shader(src.text))
        data = np.arange(256, dtype=np.float32)
        buf = ctx.buffer(data.tobytes())
        try:
            buf.bind_to_storage_buffer(0)
            shader.run(256 // 64)
            ctx.memory_barrier()
            out = np.frombuffer(buf.read(), dtype=np.float32)
        finally:
            buf.release()
            shader.release()
        ok = bool(np.allclose(out, data * 2 + np.pi, rtol=1e-6))
        ms = (time.perf_counter() - t0) * 1e3
        return {"ok": ok, "detail": f"compute shader with {src_path.name} ran in {ms:.1f} ms"
                + ("" if ok else ", but returned wrong numbers")}
    except Exception as exc:
        return {"ok": False, "detail": f"{type(exc).__name__}: {exc}"}

"""Clear a single-sample colour texture, or fill a buffer's words, with a compute shader.

    clear_texture(ctx, texture, (0.0, 0.0, 0.0, 0.0))
    fill_words(ctx, buffer, 0xFFFFFFFF)

On the H200 (driver 580.159.04, 2026-12-02) a 1920x1080 RGBA16F texture took 0.29 ms to clear
through a framebuffer (``glClear``: the few raster units of a GPU built for computing) and
0.010 ms by ``imageStore`` from a compute shader; its 32-bit depth 0.11 ms (depth cannot be an
image, so depth keeps ``glClear``). A multisampled renderbuffer cannot be an image either.

``fill_words`` sets a buffer's words on the GPU: the transparency methods' per-frame clears, and
the compute rasteriser's per-sample words when a renderer first draws (or changes size), which
at 1080p (3840 x 2160 samples, 100 MB) were built in host memory and uploaded.
"""
from __future__ import annotations

from pathlib import Path

import moderngl

from ..errors import UsageError
from .bindings import B_FILL, IMG_CLEAR
from .glsl import ProgramMemo, compute_shader
from .uniforms import write_uniform

HERE = Path(__file__).resolve().parent
SOURCE = HERE / "clear_image.comp"
FILL_SOURCE = HERE / "fill_words.comp"
FILL_GROUPS = 4096   # work groups at most (the kernel strides over the rest)
FILL_BARRIERS = moderngl.SHADER_STORAGE_BARRIER_BIT | moderngl.BUFFER_UPDATE_BARRIER_BIT
BARRIERS = (moderngl.FRAMEBUFFER_BARRIER_BIT | moderngl.TEXTURE_FETCH_BARRIER_BIT
            | moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)   # later draws, fetches and image loads see it
LOCAL = 16
# (components, dtype) -> the image format the shader declares
FORMATS = {(4, "f2"): "rgba16f", (4, "f4"): "rgba32f", (1, "f4"): "r32f", (2, "f4"): "rg32f", (4, "f1"): "rgba8"}


def image_format(texture) -> str:
    """The GLSL image format of ``texture`` (UsageError for a kind this module cannot clear)."""
    key = (int(texture.components), str(texture.dtype))
    if key not in FORMATS or getattr(texture, "samples", 0) > 1:
        raise UsageError(f"cannot clear a {texture.components}-component {texture.dtype} texture "
                         f"with {getattr(texture, 'samples', 0)} samples by compute; formats: "
                         f"{', '.join(f'{c}x{d}' for c, d in FORMATS)}, single-sampled")
    return FORMATS[key]


def clear_texture(ctx, texture, value=(0.0, 0.0, 0.0, 0.0), programs: ProgramMemo | None = None) -> None:
    """Set every texel of ``texture`` (level 0) to ``value`` (RGBA; unused channels ignored),
    then a barrier so that later draws, fetches and image loads see it. ``programs``: the
    caller's ProgramMemo, which keeps the kernel (else it is looked up in the shader cache)."""
    fmt = image_format(texture)

    def build():
        return compute_shader(ctx, SOURCE, defines={"FORMAT": fmt})

    cs = build() if programs is None else programs.get(("clear_image", fmt), (), build)
    w, h = texture.size
    write_uniform(cs["size"], (int(w), int(h)))
    write_uniform(cs["value"], tuple(map(float, value)))
    texture.bind_to_image(IMG_CLEAR, read=False, write=True)
    cs.run((w + LOCAL - 1) // LOCAL, (h + LOCAL - 1) // LOCAL)
    ctx.memory_barrier(BARRIERS)


def fill_words(ctx, buffer, value: int, programs: ProgramMemo | None = None, *, count: int | None = None,
               barrier: bool = True) -> None:
    """Set the first ``count`` 32-bit words of ``buffer`` (default: every word; the size a
    multiple of 4) to ``value`` on the GPU, then (``barrier``) a barrier so that later shader
    accesses and reads see it (callers that clear several buffers give one barrier after them).
    ``programs``: as clear_texture's. The buffer is bound at ``B_FILL`` afterwards (callers bind
    theirs before use)."""
    size = int(buffer.size)
    if count is None:
        if size % 4:
            raise UsageError(f"cannot fill a {size}-byte buffer by 32-bit words")
        count = size // 4
    count = int(count)
    if not 0 <= count <= size // 4:
        raise UsageError(f"cannot fill {count} words of a {size}-byte buffer")
    value = int(value)
    if not 0 <= value <= 0xFFFFFFFF:
        raise UsageError(f"a fill word must be 0 .. 0xFFFFFFFF, got {value}")
    build = lambda: compute_shader(ctx, FILL_SOURCE)   # noqa: E731
    cs = build() if programs is None else programs.get("fill_words", (), build)
    write_uniform(cs["u_count"], count)
    write_uniform(cs["u_value"], value)
    buffer.bind_to_storage_buffer(B_FILL)
    cs.run(max(1, min(FILL_GROUPS, -(-count // 256))))
    if barrier:
        ctx.memory_barrier(FILL_BARRIERS)

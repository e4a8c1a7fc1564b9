"""The GLSL loader: includes, defines, the line map, program building and the program cache."""
from __future__ import annotations

import gc
import os

import pytest

from mane.errors import ShaderCompileError, UsageError
from mane.gpu import glsl
from mane.gpu.glsl import SHARED_SHADER_DIR, compute_shader, load_source, program

pytestmark = pytest.mark.gpu


def write(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def origins(src):
    return [src.origin(i + 1) for i in range(len(src.line_map))]


# ------------------------------------------------------------------ preprocessing (no GL)

def test_include_beside_the_including_file(tmp_path):
    write(tmp_path / "lib" / "b.glsl", "float b() { return 2.0; }\n")
    a = write(tmp_path / "lib" / "a.comp", '#version 430\n#include "b.glsl"\nvoid main() {}\n')
    src = load_source(a)
    assert "float b()" in src.text
    assert [p.name for p in src.files] == ["a.comp", "b.glsl"]
    line = src.text.splitlines().index("float b() { return 2.0; }") + 1
    assert src.origin(line) == f"{(tmp_path / 'lib' / 'b.glsl').resolve()}:1"


def test_include_from_the_shared_dir_and_include_dirs(tmp_path):
    extra = write(tmp_path / "extra" / "x.glsl", "float x() { return 1.0; }\n").parent
    a = write(tmp_path / "a.comp", '#version 430\n#include "common.glsl"\n#include <x.glsl>\nvoid main() {}\n')
    src = load_source(a, include_dirs=[extra])
    names = [p.resolve() for p in src.files]
    assert (SHARED_SHADER_DIR / "common.glsl").resolve() in names
    assert (extra / "x.glsl").resolve() in names
    assert "uint pcg_hash(uint v)" in src.text


def test_the_including_dir_comes_before_the_shared_dir(tmp_path):
    write(tmp_path / "common.glsl", "float mine() { return 3.0; }\n")
    a = write(tmp_path / "a.comp", '#version 430\n#include "common.glsl"\nvoid main() {}\n')
    src = load_source(a)
    assert "float mine()" in src.text and "pcg_hash" not in src.text


def test_each_file_is_included_once(tmp_path):
    write(tmp_path / "d.glsl", "const float D = 1.0;\n")
    write(tmp_path / "b.glsl", '#include "d.glsl"\nfloat b() { return D; }\n')
    write(tmp_path / "c.glsl", '#include "d.glsl"\nfloat c() { return D; }\n')
    a = write(tmp_path / "a.comp", '#version 430\n#include "b.glsl"\n#include "c.glsl"\n#include "b.glsl"\nvoid main() {}\n')
    src = load_source(a)
    assert src.text.count("const float D = 1.0;") == 1
    assert src.text.count("float b()") == 1
    assert len(src.files) == 4


def test_circular_include_is_an_error(tmp_path):
    write(tmp_path / "b.glsl", '#include "c.glsl"\n')
    write(tmp_path / "c.glsl", '#include "b.glsl"\n')
    a = write(tmp_path / "a.comp", '#version 430\n#include "b.glsl"\n')
    with pytest.raises(ShaderCompileError, match=r"circular #include \(a.comp -> b.glsl -> c.glsl -> b.glsl\)"):
        load_source(a)


def test_missing_include_names_file_and_line(tmp_path):
    a = write(tmp_path / "a.comp", '#version 430\n\n\n#include "nowhere.glsl"\n')
    with pytest.raises(ShaderCompileError) as info:
        load_source(a)
    assert f"{a.resolve()}:4" in str(info.value)
    assert '"nowhere.glsl"' in str(info.value)


def test_defines_come_after_version_and_extensions(tmp_path):
    a = write(tmp_path / "a.comp", "// a comment first\n#version 430 core\n"
              "#extension GL_ARB_gpu_shader_int64 : enable\nlayout(local_size_x = 1) in;\nvoid main() {}\n")
    src = load_source(a, defines={"N": 8, "FAST": True, "SLOW": False, "SCALE": 0.5})
    lines = src.text.splitlines()
    assert lines[0] == "#version 430 core"
    assert lines[1].startswith("#extension GL_ARB_gpu_shader_int64")
    assert lines[2:6] == ["#define N 8", "#define FAST 1", "#define SLOW 0", "#define SCALE 0.5"]
    assert src.origin(3).startswith("<injected>")
    assert src.origin(1).endswith("a.comp:2") and src.origin(7).endswith("a.comp:4")


def test_default_version_when_the_file_has_none(tmp_path):
    a = write(tmp_path / "a.comp", "layout(local_size_x = 1) in;\nvoid main() {}\n")
    src = load_source(a, defines={"K": 1})
    assert src.text.splitlines()[:2] == [glsl.DEFAULT_VERSION, "#define K 1"]


def test_bad_define_name(tmp_path):
    a = write(tmp_path / "a.comp", "#version 430\n")
    with pytest.raises(UsageError):
        load_source(a, defines={"1BAD": 1})


def test_included_extension_is_hoisted_but_conditional_ones_stay(tmp_path):
    write(tmp_path / "i64.glsl", "float helper() { return 1.0; }\n#extension GL_ARB_gpu_shader_int64 : require\n"
          "#ifdef WANT_BALLOT\n#extension GL_ARB_shader_ballot : require\n#endif\n")
    a = write(tmp_path / "a.comp", '#version 430\nlayout(local_size_x = 1) in;\n#include "i64.glsl"\nvoid main() {}\n')
    src = load_source(a)
    lines = src.text.splitlines()
    assert lines[1] == "#extension GL_ARB_gpu_shader_int64 : require"
    assert src.origin(2).endswith("i64.glsl:2")
    assert lines.index("#extension GL_ARB_shader_ballot : require") > lines.index("#ifdef WANT_BALLOT")


def test_include_text_in_comments_is_defused(tmp_path):
    # moderngl itself replaces `#include "x"` anywhere in a source, comments included.
    write(tmp_path / "b.glsl", '// use: #include "b.glsl"\nfloat b() { return 1.0; }\n')
    a = write(tmp_path / "a.comp", '#version 430\n#include "b.glsl"\n')
    assert '#include "' not in load_source(a).text


# ------------------------------------------------------------------ building on the GL context

COMPUTE_OK = "#version 430\nlayout(local_size_x = 1) in;\nlayout(std430, binding = 0) buffer B { float v[]; };\n"


def test_defines_reach_the_compiled_shader(gl, tmp_path):
    import numpy as np

    a = write(tmp_path / "a.comp", COMPUTE_OK + "void main() { v[0] = float(VALUE); }\n")
    shader = compute_shader(gl, a, defines={"VALUE": 42})
    buf = gl.buffer(reserve=4)
    buf.bind_to_storage_buffer(0)
    shader.run(1)
    gl.memory_barrier()
    assert np.frombuffer(buf.read(), np.float32)[0] == 42
    buf.release()


def test_hoisted_extension_compiles(gl, tmp_path):
    if "GL_ARB_gpu_shader_int64" not in gl.extensions:
        pytest.skip("no GL_ARB_gpu_shader_int64")
    write(tmp_path / "i64.glsl", "float helper() { return 1.0; }\n#extension GL_ARB_gpu_shader_int64 : require\n"
          "uint64_t widen(uint x) { return uint64_t(x) << 32; }\n")
    a = write(tmp_path / "a.comp", COMPUTE_OK + '#include "i64.glsl"\nvoid main() { v[0] = float(widen(1u) >> 32); }\n')
    compute_shader(gl, a)


def test_compile_error_names_the_included_file_and_line(gl, tmp_path):
    write(tmp_path / "inc.glsl", "float fine() { return 1.0; }\n\nfloat broken() { return undeclared_thing; }\n")
    a = write(tmp_path / "main.comp", COMPUTE_OK + '#include "inc.glsl"\nvoid main() { v[0] = fine(); }\n')
    with pytest.raises(ShaderCompileError) as info:
        compute_shader(gl, a, defines={"ALPHA": 1, "BETA": 2})
    message = str(info.value)
    assert f"{(tmp_path / 'inc.glsl').resolve()}:3" in message, message
    assert "undeclared_thing" in message


def test_compile_error_in_the_main_file(gl, tmp_path):
    a = write(tmp_path / "main.comp", COMPUTE_OK + '#include "common.glsl"\n\nvoid main() { v[0] = nope; }\n')
    with pytest.raises(ShaderCompileError) as info:
        compute_shader(gl, a)
    assert f"{a.resolve()}:6" in str(info.value)


VERT = "#version 430\nin vec3 in_pos;\nvoid main() { gl_Position = vec4(in_pos, 1.0); }\n"
FRAG = '#version 430\n#include "common.glsl"\nout vec4 color;\nvoid main() { color = vec4(saturate(PI)); }\n'
TESC = """#version 430
layout(vertices = 4) out;
void main() {
    gl_out[gl_InvocationID].gl_Position = gl_in[gl_InvocationID].gl_Position;
    if (gl_InvocationID == 0) { gl_TessLevelOuter[0] = 1.0; gl_TessLevelOuter[1] = float(SEGMENTS); }
}
"""
TESE = """#version 430
#include "common.glsl"
layout(isolines, equal_spacing) in;
void main() {
    float t = gl_TessCoord.x;
    gl_Position = vec4(catmull_rom(gl_in[0].gl_Position.xyz, gl_in[1].gl_Position.xyz,
                                   gl_in[2].gl_Position.xyz, gl_in[3].gl_Position.xyz, t), 1.0);
}
"""
GEOM = """#version 430
layout(lines) in;
layout(triangle_strip, max_vertices = 4) out;
void main() {
    vec4 side = vec4(0.01, 0.0, 0.0, 0.0);
    gl_Position = gl_in[0].gl_Position - side; EmitVertex();
    gl_Position = gl_in[0].gl_Position + side; EmitVertex();
    gl_Position = gl_in[1].gl_Position - side; EmitVertex();
    gl_Position = gl_in[1].gl_Position + side; EmitVertex();
    EndPrimitive();
}
"""


def test_vertex_fragment_program(gl, tmp_path):
    prog = program(gl, vertex=write(tmp_path / "s.vert", VERT), fragment=write(tmp_path / "s.frag", FRAG))
    assert "in_pos" in prog


def test_tessellation_and_geometry_program_draws(gl, tmp_path):
    import moderngl
    import numpy as np

    prog = program(gl, vertex=write(tmp_path / "s.vert", VERT), tess_control=write(tmp_path / "s.tesc", TESC),
                   tess_evaluation=write(tmp_path / "s.tese", TESE), geometry=write(tmp_path / "s.geom", GEOM),
                   fragment=write(tmp_path / "s.frag", FRAG), defines={"SEGMENTS": 8})
    pts = np.array([[-0.9, -0.5, 0], [-0.3, 0.5, 0], [0.3, -0.5, 0], [0.9, 0.5, 0]], np.float32)
    vbo = gl.buffer(pts.tobytes())
    vao = gl.vertex_array(prog, [(vbo, "3f", "in_pos")])
    fbo = gl.simple_framebuffer((32, 32))
    previous = gl.fbo  # the session context is shared: leave its bound framebuffer as found
    try:
        fbo.use()
        fbo.clear()
        gl.patch_vertices = 4
        vao.render(moderngl.PATCHES, vertices=4)
        image = np.frombuffer(fbo.read(components=4), np.uint8)
    finally:
        if previous is not None:
            previous.use()
        else:
            gl.fbo = None
        for obj in (vao, vbo, fbo):
            obj.release()
    assert image.max() > 0  # the tessellated, expanded strand covered some pixels


# ------------------------------------------------------------------ the program cache

class FakeShader:
    def __init__(self, text):
        self.text = text


class FakeContext:
    """Stands in for a moderngl Context: the cache only calls compute_shader()."""

    def __init__(self):
        self.built = 0

    def compute_shader(self, text):
        self.built += 1
        return FakeShader(text)


def test_cache_hits_and_keys(tmp_path):
    ctx = FakeContext()
    a = write(tmp_path / "a.comp", "#version 430\nvoid main() {}\n")
    s1 = compute_shader(ctx, a)
    assert compute_shader(ctx, a) is s1 and ctx.built == 1
    assert compute_shader(ctx, a, defines={"X": 1}) is not s1 and ctx.built == 2


def test_cache_rebuilds_when_an_included_file_changes(tmp_path, monkeypatch):
    monkeypatch.setattr(glsl, "RECHECK_SECONDS", 0.0)
    ctx = FakeContext()
    inc = write(tmp_path / "inc.glsl", "const float K = 1.0;\n")
    a = write(tmp_path / "a.comp", '#version 430\n#include "inc.glsl"\nvoid main() {}\n')
    s1 = compute_shader(ctx, a)
    inc.write_text("const float K = 2.0;\n")
    st = inc.stat()
    os.utime(inc, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000))
    s2 = compute_shader(ctx, a)
    assert s2 is not s1 and "K = 2.0" in s2.text


def test_cache_is_per_context_and_forgets_dead_ones(tmp_path):
    a = write(tmp_path / "a.comp", "#version 430\nvoid main() {}\n")
    one, two = FakeContext(), FakeContext()
    assert compute_shader(one, a) is not compute_shader(two, a)
    before = len(glsl._cache)
    del one
    gc.collect()
    assert len(glsl._cache) == before - 1
    glsl.clear_cache(two)
    assert two not in glsl._cache

"""Blender's cross-backend rules, read statically from every shader spec, GLSL file and GPU call of the extension, so
that what cannot run here (Metal) is held to what runs on OpenGL, Vulkan and Metal alike. Each rule has a planted
violation that the checker must catch. The rules and the reasons behind them: docs/gpu_backends.md.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from translucent_addon.gpu import shaders
from translucent_addon.gpu.targets import TEXTURE_FORMATS
from translucent_addon.techniques import REGISTRY

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "translucent_addon"

FORMATS = TEXTURE_FORMATS  # gpu/targets.py says why these
OFFSCREEN_FORMATS = {"RGBA8", "RGBA16F", "RGBA32F"}
# Per-shader limits that hold on all three backends (the smallest of OpenGL 4.3's minimums, Vulkan's required
# limits and Blender's Metal backend): samplers per stage, uniform blocks, vertex inputs, colour outputs, and the
# push-constant bytes Vulkan guarantees (maxPushConstantsSize >= 128).
MAX_SAMPLERS, MAX_UNIFORM_BLOCKS, MAX_VERTEX_IN, MAX_FRAGMENT_OUT, MAX_PUSH_BYTES = 16, 12, 16, 8, 128
PUSH_SIZE = {"INT": 4, "UINT": 4, "FLOAT": 4, "BOOL": 4, "VEC2": 8, "IVEC2": 8, "VEC3": 12, "IVEC3": 12, "VEC4": 16,
             "IVEC4": 16, "MAT3": 48, "MAT4": 64}
PUSH_ALIGN = {"VEC3": 16, "IVEC3": 16, "VEC4": 16, "IVEC4": 16, "MAT3": 16, "MAT4": 16, "VEC2": 8, "IVEC2": 8}
# GLSL that only an OpenGL compatibility profile knows, or that bypasses GPUShaderCreateInfo (the interface must come
# from the spec so Blender can translate it to SPIR-V and MSL).
GLSL_FORBIDDEN = {
    r"\bgl_FragColor\b": "gl_FragColor (declare a fragment_out)",
    r"\bgl_FragData\b": "gl_FragData (declare fragment_out slots)",
    r"\btexture(2D|3D|Cube)\s*\(": "texture2D/3D/Cube (use texture / texelFetch)",
    r"\bgl_(ModelView|Projection|Normal)Matrix": "fixed-function matrices (pass them in a uniform block)",
    r"\bgl_(Vertex|Normal|Color|MultiTexCoord\d)\b": "fixed-function attributes (declare vertex_in)",
    r"^\s*#\s*version\b": "#version (Blender writes it per backend)",
    r"^\s*(uniform|attribute|varying|in|out|flat|smooth|layout)\b[^(]*;\s*$":
        "a global interface declaration (declare it in the ShaderSpec)",
    r"\bimage(Load|Store)\s*\(": "image load/store (not in the spec's interface)",
}


def spec_violations(name: str, spec: shaders.ShaderSpec) -> list[str]:
    """What in one shader spec would not run on every backend."""
    out = []
    if len(spec.samplers) > MAX_SAMPLERS:
        out.append(f"{name}: {len(spec.samplers)} samplers (at most {MAX_SAMPLERS})")
    if len(spec.uniform_blocks) > MAX_UNIFORM_BLOCKS:
        out.append(f"{name}: {len(spec.uniform_blocks)} uniform blocks (at most {MAX_UNIFORM_BLOCKS})")
    if len(spec.vertex_in) > MAX_VERTEX_IN:
        out.append(f"{name}: {len(spec.vertex_in)} vertex inputs (at most {MAX_VERTEX_IN})")
    if len(spec.fragment_out) > MAX_FRAGMENT_OUT:
        out.append(f"{name}: {len(spec.fragment_out)} fragment outputs (at most {MAX_FRAGMENT_OUT})")
    offset = 0
    for kind, const in spec.push_constants:
        if kind not in PUSH_SIZE:
            out.append(f"{name}: push constant {const} of type {kind} has no size here")
            continue
        align = PUSH_ALIGN.get(kind, 4)
        offset = -(-offset // align) * align + PUSH_SIZE[kind]
    if offset > MAX_PUSH_BYTES:
        out.append(f"{name}: {offset} bytes of push constants (at most {MAX_PUSH_BYTES})")
    for slots, what in ((spec.samplers, "sampler"), (spec.uniform_blocks, "uniform block"),
                        (spec.fragment_out, "fragment output")):
        numbers = [s[0] for s in slots]
        if len(set(numbers)) != len(numbers):
            out.append(f"{name}: two {what}s share a slot ({numbers})")
    return out


def glsl_violations(label: str, text: str) -> list[str]:
    """GLSL that only some backends take, line by line (comments removed first)."""
    text = re.sub(r"/\*.*?\*/", lambda m: "\n" * m.group(0).count("\n"), text, flags=re.S)
    out = []
    for number, line in enumerate(text.splitlines(), 1):
        line = line.split("//", 1)[0]
        for pattern, why in GLSL_FORBIDDEN.items():
            if re.search(pattern, line):
                out.append(f"{label}:{number}: {why}: {line.strip()}")
    return out


def _string(node) -> str | None:
    return node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else None


def call_violations(label: str, source: str) -> list[str]:
    """GPU calls in Python source that break a backend rule: a texture or off-screen format outside the allowed
    sets (or not a literal), a read-back of fewer than four channels (Vulkan writes every component of the texture,
    overrunning the buffer), a shader made other than through GPUShaderCreateInfo."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Call):
            continue
        func = node.func
        name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
        keywords = {k.arg: k.value for k in node.keywords}
        where = f"{label}:{node.lineno}"
        if name in ("GPUTexture", "texture_from_array", "GPUOffScreen"):
            fmt = keywords.get("format")
            if fmt is None and name == "texture_from_array" and len(node.args) > 1:
                fmt = node.args[1]
            if fmt is None:
                continue  # the default: RGBA8 for GPUTexture and GPUOffScreen, RGBA32F for texture_from_array
            value = _string(fmt)
            allowed = OFFSCREEN_FORMATS if name == "GPUOffScreen" else FORMATS
            if value is None and label.endswith("gpu/targets.py"):
                continue  # texture_from_array's own parameter, checked against TEXTURE_FORMATS when called
            if value is None:
                out.append(f"{where}: {name} format is not a literal (the rule cannot be checked)")
            elif value not in allowed:
                out.append(f"{where}: {name} format {value} is not taken by every backend")
        elif name == "read_color":
            channels = node.args[4] if len(node.args) > 4 else keywords.get("channels")
            if not (isinstance(channels, ast.Constant) and channels.value == 4):
                out.append(f"{where}: read_color of fewer than 4 channels (Vulkan writes all 4)")
        elif name in ("GPUShader", "from_builtin_code", "create_from_string"):
            out.append(f"{where}: a shader made by {name}, not through GPUShaderCreateInfo")
        elif name == "create_from_info" and not label.endswith("gpu/shaders.py"):
            out.append(f"{where}: a shader built outside gpu/shaders.py")
    return out


STATE_SETTERS = re.compile(r"\bgpu\.state\.(blend_set|depth_test_set|depth_mask_set)\s*\(")


def state_violations(label: str, source: str) -> list[str]:
    """Blend, depth test or depth writes set outside gpu/draw_state.py: a pass states them through ``draw_pass``,
    which restores them, so nothing one pass sets reaches the next."""
    if label.endswith("gpu/draw_state.py"):
        return []
    lines = enumerate(source.splitlines(), 1)
    return [f"{label}:{n}: {line.strip()}" for n, line in lines if STATE_SETTERS.search(line)]


def _python_sources():
    return sorted(p for p in PACKAGE.rglob("*.py"))


def test_every_shader_spec_is_within_every_backends_limits():
    specs = dict(shaders.SPECS)
    for technique in REGISTRY:
        specs.update(technique.shader_specs)
    assert len(specs) > 25
    problems = [p for name, spec in specs.items() for p in spec_violations(name, spec)]
    assert not problems, "\n".join(problems)


def test_every_glsl_file_uses_only_what_every_backend_takes():
    files = sorted(shaders.SHADER_DIR.rglob("*.glsl"))
    assert len(files) > 30
    problems = [p for f in files for p in glsl_violations(f.name, f.read_text())]
    assert not problems, "\n".join(problems)


def test_every_gpu_call_uses_formats_and_read_backs_every_backend_takes():
    problems = [p for f in _python_sources() for p in call_violations(str(f.relative_to(ROOT)), f.read_text())]
    assert not problems, "\n".join(problems)


def test_every_pass_sets_its_gpu_state_through_draw_pass():
    problems = [p for f in _python_sources() for p in state_violations(str(f.relative_to(ROOT)), f.read_text())]
    assert not problems, "\n".join(problems)


def test_a_planted_state_setter_is_caught():
    source = 'with fb.bind():\n    gpu.state.blend_set("ADDITIVE_PREMULT")\n    shader.draw(batch)\n'
    expected = 'techniques/x/passes.py:2: gpu.state.blend_set("ADDITIVE_PREMULT")'
    assert state_violations("techniques/x/passes.py", source) == [expected]
    assert state_violations("translucent_addon/gpu/draw_state.py", source) == []


def test_every_pass_sets_its_inputs_through_pass_shader():
    """Push constants set before a sampler are lost on Blender 5.3's OpenGL (docs/gpu_backends.md): a pass binds,
    sets and draws through ``shaders.PassShader``, never a bare GPUShader (``shaders.get`` only builds batches)."""
    problems = []
    for f in _python_sources():
        if f.name == "shaders.py" and f.parent.name == "gpu":
            continue
        for number, line in enumerate(f.read_text().splitlines(), 1):
            bare_shader = re.search(r"=\s*shaders\.get\(", line)
            drawn_with_one = re.search(r"\.draw(_instanced)?\(\s*\w*shader\w*\s*[,)]", line)
            if bare_shader or drawn_with_one:
                problems.append(f"{f.relative_to(ROOT)}:{number}: {line.strip()}")
    assert not problems, "\n".join(problems)


# -- planted violations: the checker catches each ------------------------------------------------------------------
@pytest.mark.parametrize("source, expected", [
    ('gpu.types.GPUTexture((4, 4), format="RGB32F")', "RGB32F is not taken"),
    ('texture_from_array(image, "RGB16F")', "RGB16F is not taken"),
    ('gpu.types.GPUTexture(size, format="DEPTH24_STENCIL8")', "DEPTH24_STENCIL8 is not taken"),
    ('gpu.types.GPUOffScreen(8, 8, format="R32F")', "R32F is not taken"),
    ('gpu.types.GPUTexture(size, format=fmt)', "not a literal"),
    ('texture_from_array(image, "RGB32F")', "RGB32F is not taken"),
    ('fb.read_color(0, 0, w, h, 3, 0, "FLOAT", data=buf)', "fewer than 4 channels"),
    ('gpu.types.GPUShader(vertex_code, fragment_code)', "not through GPUShaderCreateInfo"),
    ('gpu.shader.create_from_info(info)', "outside gpu/shaders.py"),
])
def test_a_planted_gpu_call_violation_is_caught(source, expected):
    problems = call_violations("planted.py", source)
    assert len(problems) == 1 and expected in problems[0], problems


def test_allowed_gpu_calls_pass():
    source = ('gpu.types.GPUTexture((4, 4), format="RGBA16F")\ntexture_from_array(image)\n'
              'fb.read_color(0, 0, w, h, 4, slot, "FLOAT", data=buf)\ngpu.types.GPUOffScreen(8, 8, format="RGBA32F")')
    assert call_violations("fine.py", source) == []


@pytest.mark.parametrize("glsl, expected", [
    ("void main() { gl_FragColor = vec4(1.0); }", "gl_FragColor"),
    ("vec4 c = texture2D(tex, uv);", "texture2D"),
    ("#version 330", "#version"),
    ("uniform sampler2D extra;", "global interface declaration"),
    ("out vec4 colour;", "global interface declaration"),
    ("imageStore(img, ivec2(0), vec4(0.0));", "image load/store"),
])
def test_a_planted_glsl_violation_is_caught(glsl, expected):
    problems = glsl_violations("planted.glsl", glsl)
    assert len(problems) == 1 and expected in problems[0], problems


def test_glsl_in_comments_and_function_parameters_passes():
    glsl = "/* gl_FragColor was */\nvoid f(in vec3 a, out vec3 b) { b = a; } // texture2D(\n"
    assert glsl_violations("fine.glsl", glsl) == []


@pytest.mark.parametrize("spec, expected", [
    (shaders.ShaderSpec(source="x.glsl", samplers=tuple((k, "FLOAT_2D", f"s{k}") for k in range(17))), "17 samplers"),
    (shaders.ShaderSpec(source="x.glsl", push_constants=tuple(("MAT4", f"m{k}") for k in range(3))), "192 bytes"),
    (shaders.ShaderSpec(source="x.glsl", fragment_out=tuple((k, "VEC4", f"o{k}") for k in range(9))), "9 fragment"),
    (shaders.ShaderSpec(source="x.glsl", samplers=((0, "FLOAT_2D", "a"), (0, "FLOAT_2D", "b"))), "share a slot"),
])
def test_a_planted_spec_violation_is_caught(spec, expected):
    problems = spec_violations("planted", spec)
    assert len(problems) == 1 and expected in problems[0], problems

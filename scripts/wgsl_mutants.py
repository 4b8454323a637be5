#!/usr/bin/env python3
"""Mutation testing for the WGSL shaders, which cargo-mutants cannot mutate.

Each mutant below is one deliberate break of a shading behaviour: a textual
edit that must apply to exactly one place. For each, the script applies the
edit, runs the rendering tests (RENDER_TESTS, on lavapipe),
records whether any test failed ("caught") or all passed ("missed"), and
restores the file, whatever happens. The table it prints goes into
docs/testing.md.

    scripts/wgsl_mutants.py                 # every mutant (about 2-4 minutes each on 2 cores)
    scripts/wgsl_mutants.py pcf bias        # only mutants whose name contains one of the words

Not part of CI: a full run takes about as long as the mutants times one
build and run of the GPU tests.
"""

import pathlib
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
SHADER = "oxygen-passes/src/forward_lit.wgsl"
TONEMAP = "oxygen-passes/src/tonemap_pass.wgsl"
VERTEX = "oxygen-passes/src/mesh_vertex.wgsl"
DEPTH = "oxygen-passes/src/depth_only.wgsl"

# (name, file, old text, new text, what the mutant breaks)
MUTANTS = [
    ("cascade-pcf-off", SHADER, "let r = i32(shadows.pcf_radius);", "let r = 0;",
     "cascade PCF radius ignored (hard shadow edges)"),
    ("cascade-normal-offset-off", SHADER,
     "let offset = geometric_normal * shadows.texel_world_size[i] * shadows.normal_offset;",
     "let offset = vec3<f32>(0.0);", "cascade lookups without the normal offset"),
    ("cascade-no-shadow", SHADER, "return lit / taps;", "return 1.0;",
     "cascades never shadow"),
    ("tile-no-shadow", SHADER, "return lit / 9.0;", "return 1.0;",
     "spot and point shadow tiles never shadow"),
    ("double-sided-normal-not-flipped", SHADER, "let oriented = select(world_normal, -world_normal, flip);",
     "let oriented = world_normal;", "back faces of double-sided surfaces lit with the front normal"),
    ("brdf-no-n-dot-l", SHADER, "return (diffuse + distribution * visibility * fresnel) * n_dot_l;",
     "return (diffuse + distribution * visibility * fresnel);", "BRDF without the cosine term"),
    ("brdf-no-specular", SHADER, "return (diffuse + distribution * visibility * fresnel) * n_dot_l;",
     "return diffuse * n_dot_l;", "no specular lobe"),
    ("brdf-no-fresnel-diffuse-split", SHADER,
     "let diffuse = (vec3<f32>(1.0) - fresnel) * (1.0 - metallic) * albedo / PI;",
     "let diffuse = albedo / PI;", "metals keep a diffuse term"),
    ("spot-cone-ignored", SHADER,
     "attenuation *= spot_cone(light.cos_outer, light.cos_inner, dot(-l, light.direction));", "",
     "spot lights light outside their cone"),
    ("range-falloff-ignored", SHADER, "attenuation *= clamp(1.0 - ratio * ratio * ratio * ratio, 0.0, 1.0);", "",
     "positional lights reach past their range"),
    ("inverse-square-ignored", SHADER, "var attenuation = 1.0 / distance_sq;", "var attenuation = 1.0;",
     "positional lights do not fall off with distance"),
    ("point-shadow-face-flipped", SHADER, "let tile = light.shadow_slot + cube_face(-l);",
     "let tile = light.shadow_slot + cube_face(l);", "point-light shadows read the opposite cube face"),
    ("alpha-cutoff-ignored-in-shading", SHADER, "if shaded.a < material.alpha_cutoff {", "if false {",
     "masked materials are not cut out by the shading pass"),
    ("alpha-cutoff-ignored-in-pre-pass", DEPTH, "a < material.alpha_cutoff {", "a < -1.0 {",
     "masked materials are not cut out by the depth pre-pass"),
    ("normal-matrix-replaced-by-world", VERTEX,
     "out.world_normal = normal_matrix * vec3<f32>(v.nx, v.ny, v.nz);",
     "out.world_normal = (world * vec4<f32>(v.nx, v.ny, v.nz, 0.0)).xyz;",
     "normals transformed by the world matrix instead of the inverse transpose"),
    ("generation-check-off", VERTEX, "if checking && draw.reserved0 != scene.renderer.draw_metadata_generation {",
     "if false {", "stale draw ranges are not flagged in debug mode"),
    ("tonemap-exposure-ignored", TONEMAP, "safe * params.exposure", "safe", "exposure has no effect"),
]


# The test binaries that render (the shaders cannot change anything else).
RENDER_TESTS = [
    "gpu_render", "gpu_golden", "gpu_textures", "gpu_debug_generations", "gpu_heap", "probes",
    "shadow_cascades", "shadow_quality", "shading_finite", "draw_order", "normal_matrix_render",
    "light_gating", "gltf_negative_scale", "huge_world", "frame_isolation", "tonemap_exposure",
]


def run_tests() -> bool:
    """True when every rendering test passes."""
    command = ["cargo", "test", "--quiet", "-p", "oxygen"]
    for name in RENDER_TESTS:
        command += ["--test", name]
    result = subprocess.run(command, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=3600)
    return result.returncode == 0


def main() -> int:
    words = sys.argv[1:]
    chosen = [m for m in MUTANTS if not words or any(w in m[0] for w in words)]
    rows = []
    started_all = time.time()
    if not run_tests():
        print("the unmutated shaders fail the rendering tests: fix that first", file=sys.stderr)
        return 1
    print(f"baseline passes ({time.time() - started_all:.0f} s)", file=sys.stderr, flush=True)
    for name, file, old, new, what in chosen:
        path = ROOT / file
        source = path.read_text()
        count = source.count(old)
        if count != 1 or old == new:
            rows.append((name, what, f"not applicable ({count} matches)", 0.0))
            continue
        started = time.time()
        try:
            path.write_text(source.replace(old, new))
            caught = not run_tests()
        finally:
            path.write_text(source)
        seconds = time.time() - started
        rows.append((name, what, "caught" if caught else "MISSED", seconds))
        print(f"{name}: {'caught' if caught else 'MISSED'} ({seconds:.0f} s)", file=sys.stderr, flush=True)
    applicable = [r for r in rows if r[2] in ("caught", "MISSED")]
    caught = sum(1 for r in applicable if r[2] == "caught")
    print("| mutant | breaks | result | seconds |")
    print("|---|---|---|---:|")
    for name, what, result, seconds in rows:
        print(f"| `{name}` | {what} | {result} | {seconds:.0f} |")
    if applicable:
        print(f"\n{caught} of {len(applicable)} caught "
              f"({100.0 * caught / len(applicable):.0f} %), {time.time() - started_all:.0f} s in all")
    return 0


if __name__ == "__main__":
    sys.exit(main())

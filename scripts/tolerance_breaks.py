#!/usr/bin/env python3
"""Shows that each tolerance tightened in issue 27 bites: for every entry
below, breaks the behaviour the test guards (one textual edit of the
product, never of the test), runs that one test on the current backend,
expects it to FAIL at one of its assertions, and restores the file whatever
happens.

    scripts/tolerance_breaks.py            # every break (a rebuild and one test each)
    scripts/tolerance_breaks.py furnace    # those whose name contains a word

First every chosen test runs once on the unbroken product and must PASS
(else the script stops, naming it: a test already failing would count as
catching its break). A break is "caught" only when its test fails at an
assertion: the output has the test's own panic "'<test>' panicked at
tests/..." (a helper under tests/ included); a build error stops the
script, and a panic elsewhere (a shader that no longer validates, inside
the library) counts as MISSED. Tests run as scripts/wgsl_mutants.py runs
them (CI=1: no golden written from a broken product) and without
OXYGEN_RECORD_DIR (no record from this run).

The file is restored on an exception, Ctrl-C, SIGTERM or SIGHUP; a run
killed with -9 leaves a journal in target/tolerance-breaks/ that the next
start restores from. That machinery is scripts/wgsl_mutants.py's, imported
(`applied`, `recover_from_journal`, `run`), with its own journal. Each
test's cargo output goes to target/tolerance-breaks/logs/.

Prints one line per break (caught / MISSED) and exits non-zero when a
break was missed or its text no longer matches. Not part of CI: each break
rebuilds the crates it touches.
"""

import importlib.util
import pathlib
import re
import signal
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
LIT = "oxygen-passes/src/mesh/forward_lit.wgsl"

# (name, file, old, new, test binary, test name, what the break does)
BREAKS = [
    ("furnace-irradiance-5pc", LIT,
     "environment_irradiance(n) * (occlusion / PI)", "environment_irradiance(n) * (1.05 * occlusion / PI)",
     "environment", "a_rough_white_sphere_in_a_uniform_environment_shows_the_environment",
     "the environment's diffuse light 5 % too bright (the old bound allowed 20 %)"),
    ("furnace-msaa-irradiance-5pc", LIT,
     "environment_irradiance(n) * (occlusion / PI)", "environment_irradiance(n) * (1.05 * occlusion / PI)",
     "environment", "multisampled_views_draw_the_environment_too",
     "as above, on the multisampled view"),
    ("split-sum-256-samples", "oxygen-passes/src/lighting/split_sum.wgsl",
     "const SAMPLES: u32 = 1024u;", "const SAMPLES: u32 = 256u;",
     "environment", "the_split_sum_table_matches_its_cpu_twin",
     "the split-sum table integrated with a quarter of its samples"),
    ("rg11b10-exposure-4pc", "oxygen-passes/src/post/tonemap.rs",
     "bytemuck::bytes_of(&TonemapParams { exposure: self.exposure, pad0: 0.0, pad1: 0.0, pad2: 0.0 }),",
     "bytemuck::bytes_of(&TonemapParams { exposure: self.exposure * if color.hdr.format() == "
     "wgpu::TextureFormat::Rg11b10Ufloat { 1.04 } else { 1.0 }, pad0: 0.0, pad1: 0.0, pad2: 0.0 }),",
     "frame_economy", "rg11b10_hdr_stays_within_its_documented_error_and_shows_coarser_steps",
     "the packed HDR format's tone map 4 % off (a format-dependent bug)"),
    ("msaa-one-sample-written", "oxygen-passes/src/pipelines/cache.rs",
     "            // cut-out edges stay aliased (alpha to coverage is not used).\n"
     "            multisample: wgpu::MultisampleState { count: key.samples.max(1), ..Default::default() },",
     "            // cut-out edges stay aliased (alpha to coverage is not used).\n"
     "            multisample: wgpu::MultisampleState { count: key.samples.max(1), mask: if key.samples > 1 { 0b11 } else { !0 }, ..Default::default() },",
     "msaa", "more_samples_bring_edges_closer_to_the_supersampled_picture",
     "mesh passes write two of a pixel's four samples"),
    ("instancing-capped-at-16", "oxygen-sceneprep/src/finalize/partition.rs",
     "                    last.instance_count += command.instance_count;",
     "                    last.instance_count = (last.instance_count + command.instance_count).min(16);",
     "instancing_render", "instanced_commands_draw_the_same_picture_with_fewer_commands",
     "instanced commands capped at 16 instances (the draws past the cap are lost)"),
    ("probe-gold-env-reflection-130pc", LIT,
     "        let reflected = sample_environment(reflect(-v, n), roughness);\n"
     "        let f0 = mix(vec3<f32>(0.04), albedo, metallic);\n"
     "        color += reflected * split_sum_brdf(f0, roughness, max(dot(n, v), 0.0)) * occlusion;",
     "        let reflected = sample_environment(reflect(-v, n), roughness);\n"
     "        let f0 = mix(vec3<f32>(0.04), albedo, metallic);\n"
     "        color += reflected * split_sum_brdf(f0, roughness, max(dot(n, v), 0.0)) * occlusion * 1.3;",
     "probes", "reflected_surfaces_reflect_the_environment_in_the_probe_and_the_reference",
     "the environment's reflection 30 % bright (0.298: the old bound, 0.3, passed it) (the gold sphere the probe sees)"),
    ("probe-reflection-half", LIT,
     "        let reflected = sample_probe(nearest_probe(mesh.world_position), reflect(-v, n), roughness);",
     "        let reflected = 0.5 * sample_probe(nearest_probe(mesh.world_position), reflect(-v, n), roughness);",
     "probes", "a_mirror_sphere_reflects_the_red_box_through_the_probe",
     "the probe's reflection at half strength"),
    ("shadow-map-half-resolution", LIT,
     "            let uv = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);\n            let r = i32(shadows.pcf_radius);",
     "            let uv = floor(vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5) / (2.0 * shadows.uv_texel[i])) * (2.0 * shadows.uv_texel[i]);\n            let r = i32(shadows.pcf_radius);",
     "shadow_cascades", "shadow_map_resolution_trades_edge_error",
     "cascade lookups snapped to two texels (half the map's resolution)"),
]


def load_wgsl_mutants():
    """scripts/wgsl_mutants.py as a module, its journal moved to
    target/tolerance-breaks/ (a wgsl_mutants run beside this one keeps
    its own)."""
    sys.dont_write_bytecode = True  # no scripts/__pycache__ in the tree
    spec = importlib.util.spec_from_file_location("wgsl_mutants", ROOT / "scripts" / "wgsl_mutants.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.WORK = WORK
    module.JOURNAL = WORK / "journal.json"
    return module


WORK = ROOT / "target" / "tolerance-breaks"
LOGS = WORK / "logs"
MUTANTS = load_wgsl_mutants()


def test_env():
    """wgsl_mutants' test environment (CI=1, no golden or snapshot
    written), without OXYGEN_RECORD_DIR: a passing test writes no record."""
    env = MUTANTS.test_env()
    env.pop("OXYGEN_RECORD_DIR", None)
    return env


def cargo_test(binary, tests, log):
    """(exit status, output) of the named tests of tests/<binary>.rs."""
    if log.exists():
        log.unlink()
    return MUTANTS.run(["cargo", "test", "--locked", "--test", binary, "--", "--exact", *tests],
                       log=log, env=test_env())


def baseline(chosen):
    """Every chosen test passes on the unbroken product, or the script
    stops naming those that do not."""
    tests = {}
    for _name, _path, _old, _new, binary, test, _what in chosen:
        tests.setdefault(binary, [])
        if test not in tests[binary]:
            tests[binary].append(test)
    failing = []
    for binary, names in tests.items():
        start = time.time()
        log = LOGS / f"baseline-{binary}.log"
        status, output = cargo_test(binary, names, log)
        # Each must be seen passing: --exact matching nothing passes too.
        bad = [t for t in names if not re.search(rf"^test {re.escape(t)} \.\.\. ok$", output, re.M)]
        print(f"{'passes' if not bad and status == 0 else 'FAILS '}  baseline {binary}: {len(names)} test(s)"
              f"  ({time.time() - start:.0f} s)", flush=True)
        failing += [f"{binary}::{t}" for t in bad]
        if status != 0 and not bad:
            failing.append(f"{binary} (exit status {status})")
    if failing:
        sys.exit(f"unbroken, these do not pass or no longer exist (log: {shown(LOGS)}/baseline-*.log): "
                 f"{', '.join(failing)}; a break of a failing test proves nothing: fix that first")


def shown(path):
    return str(path.relative_to(ROOT))


def breaks(chosen):
    missed = []
    for name, path, old, new, binary, test, what in chosen:
        start = time.time()
        log = LOGS / f"{name}.log"
        with MUTANTS.applied([(name, path, old, new, what)]):
            status, output = cargo_test(binary, [test], log)
        if "error[" in output or "could not compile" in output:
            sys.exit(f"{name}: the broken build does not compile (log: {shown(log)}):\n{output[-3000:]}")
        lines = output.splitlines()
        # The test's own thread panicking in a file under tests/: one of its
        # assertions (or a helper's there) failed, not the library.
        # (`thread '<test>' (<id>) panicked at tests/<file>:<line>:<column>:`;
        # the id is newer Rust's; older printed none.)
        own_panic = re.compile(rf"'{re.escape(test)}'( \(\d+\))? panicked at tests/")
        panic = next((i for i, line in enumerate(lines) if own_panic.search(line)), None)
        caught = status != 0 and panic is not None and f"test {test} ... FAILED" in output
        print(f"{'caught' if caught else 'MISSED'}  {name:34} {binary}::{test}  ({time.time() - start:.0f} s)  {what}",
              flush=True)
        if caught:
            message = lines[panic + 1] if panic + 1 < len(lines) else ""
            print(f"        {message.strip()[:200]}")
        else:
            other = next((line for line in lines if "panicked at" in line), None)
            print(f"        {other.strip()[:200] if other else f'exit status {status}, no panic'} (log: {shown(log)})")
            missed.append(name)
    return missed


def main():
    words = sys.argv[1:]
    chosen = [b for b in BREAKS if not words or any(w in b[0] for w in words)]
    if not chosen:
        sys.exit(f"no break's name contains any of: {' '.join(words)}")
    signal.signal(signal.SIGTERM, MUTANTS.raise_interrupt)
    signal.signal(signal.SIGHUP, MUTANTS.raise_interrupt)
    try:
        # What a run killed with -9 left broken, restored before the texts
        # are counted.
        MUTANTS.recover_from_journal()
        # Every break's text must match exactly once before anything runs.
        for name, path, old, _new, *_ in chosen:
            count = (ROOT / path).read_text().count(old)
            if count != 1:
                sys.exit(f"{name}: its text occurs {count} times in {path} (must be once): update the break")
        baseline(chosen)
        missed = breaks(chosen)
    except MUTANTS.Failure as e:
        sys.exit(f"tolerance_breaks: {e}")
    except KeyboardInterrupt as e:
        print(f"tolerance_breaks: interrupted ({str(e) or 'SIGINT'}); files restored", file=sys.stderr)
        sys.exit(130)
    if missed:
        sys.exit(f"missed: {', '.join(missed)}")


if __name__ == "__main__":
    main()

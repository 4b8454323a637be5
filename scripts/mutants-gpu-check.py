#!/usr/bin/env python3
"""Checks the survivors of a cargo-mutants shard against the GPU tests.

A scope mutates code against unit tests only; a survivor in code that
records GPU work (graphs, the recording executor, a renderer group's
members) is then checked here: its own diff (from the shard's
`mutants.out/diff/`) is applied to a checkout, the GPU test binaries that
reach its function run on the machine's adapter one after another until
one fails, and the file is restored. A binary that runs past its limit
counts as failing (cargo-mutants counts a timeout as caught).

    scripts/mutants-gpu-check.py OUTPUT.json TREE MUTANTS_OUT [MUTANTS_OUT ...]

TREE is the checkout to mutate (not one you are editing: a clone whose
mutated files are those of the shard's commit); each MUTANTS_OUT is a
shard's `target/mutants/SCOPE-K-of-N/mutants.out`. Results accumulate in
OUTPUT.json (a mutant already there is skipped), which
docs/records/mutants/SURVIVORS.md's verdicts were written from. Set
WGPU_BACKEND as the test command does (vulkan for lavapipe).
"""

import json
import os
import re
import signal
import subprocess
import sys
import time

# Which GPU test binaries reach a function, by a part of the mutant's name
# (first match wins).
TESTS = [
    ("PrePass::resolved", ["gpu_visibility", "gpu_render"]),
    ("StandardGraph>::record", ["gpu_render", "frame_economy", "msaa", "tonemap_exposure"]),
    ("runs_occlusion_phases", ["gpu_visibility", "hiz_pyramid"]),
    ("lit_render_graph", ["gpu_render", "shadow_cascades"]),
    ("ReferenceGraph>::record", ["reference_view"]),
    ("ForwardLitConfig expression", ["batch_views"]),
    ("record_batch", ["batch_views", "msaa"]),
    ("BatchGraph>::record", ["batch_views", "msaa"]),
    ("ShadowGraph", ["shadow_cascades"]),
    ("ProbeFaceGraph", ["probes"]),
    ("link_order", ["view_links", "shadow_cascades", "batch_views"]),
    ("Renderer::inputs", ["view_links", "shadow_cascades", "shadow_quality", "probes"]),
    ("shadow_map_input", ["shadow_cascades", "shadow_quality"]),
    ("local_shadows", ["shadow_quality", "shadow_cascades"]),
    ("Renderer::jobs", ["batch_views"]),
    ("Renderer::record", ["gpu_render", "batch_views", "frame_economy", "gpu_visibility", "cost_events", "schedules", "probes"]),
    ("run_executor", ["gpu_render", "view_links", "batch_views", "schedules"]),
    ("ViewQueue", ["view_links", "gpu_render", "batch_views"]),
    ("TaskWaker", ["view_links", "gpu_render", "batch_views"]),
    ("RendererGroup", ["renderer_group"]),
    ("render_member", ["renderer_group"]),
    ("GroupViewId", ["renderer_group"]),
    ("Schedules::", ["schedules"]),
    ("Views::", ["view_links", "batch_views"]),
    ("ShadowViews", ["shadow_cascades", "shadow_quality"]),
]

# Seconds a binary may take (building it included); unmutated, these take
# 2 to 30 s on lavapipe.
LIMIT = int(os.environ.get("OXYGEN_GPU_CHECK_LIMIT_S", "200"))


def tests_for(name):
    return next((tests for key, tests in TESTS if key in name), None)


def run_binary(tree, test):
    """(failed, detail) for one test binary of the root crate."""
    env = dict(os.environ, CARGO_TERM_COLOR="never")
    proc = subprocess.Popen(
        ["cargo", "test", "-q", "-p", "oxygen", "--test", test],
        cwd=tree, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env, start_new_session=True,
    )
    try:
        text, _ = proc.communicate(timeout=LIMIT)
    except subprocess.TimeoutExpired:
        # The test binary runs in cargo's process group: stop them all.
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        return True, f"{test}: timed out"
    if "error[E" in text or "could not compile" in text:
        return None, test
    if proc.returncode != 0:
        failed = [f for f in re.findall(r"^    (\S+)$", text, re.M) if "_" in f][:3]
        return True, f"{test}: {', '.join(failed) or 'failed (exit %d)' % proc.returncode}"
    return False, test


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    output, tree, outs = sys.argv[1], sys.argv[2], sys.argv[3:]
    results = json.load(open(output)) if os.path.exists(output) else {}
    for out in outs:
        outcomes = json.load(open(os.path.join(out, "outcomes.json")))["outcomes"]
        for outcome in outcomes:
            if outcome["summary"] != "MissedMutant":
                continue
            mutant = outcome["scenario"]["Mutant"]
            name, tests = mutant["name"], tests_for(mutant["name"])
            if name in results or tests is None:
                continue
            diff = os.path.join(out, outcome["diff_path"])
            applied = subprocess.run(["patch", "-s", mutant["file"], "-i", diff], cwd=tree, capture_output=True, text=True)
            if applied.returncode != 0:
                results[name] = {"verdict": "patch failed", "detail": applied.stdout + applied.stderr}
                continue
            started = time.time()
            verdict, detail = "survived", " ".join(tests)
            try:
                for test in tests:
                    failed, what = run_binary(tree, test)
                    if failed is None:
                        verdict, detail = "unviable", what
                        break
                    if failed:
                        verdict, detail = "caught", what
                        break
            finally:
                subprocess.run(["patch", "-R", "-s", mutant["file"], "-i", diff], cwd=tree, check=True)
                for leftover in (mutant["file"] + ".orig", mutant["file"] + ".rej"):
                    if os.path.exists(os.path.join(tree, leftover)):
                        os.remove(os.path.join(tree, leftover))
            results[name] = {"verdict": verdict, "detail": detail, "seconds": round(time.time() - started)}
            print(f"{name} -> {verdict} {detail} ({results[name]['seconds']} s)", flush=True)
            json.dump(results, open(output, "w"), indent=1)
    json.dump(results, open(output, "w"), indent=1)


if __name__ == "__main__":
    main()

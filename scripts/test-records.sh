#!/usr/bin/env bash
# Runs the GPU tests whose measurements the docs quote, on the current
# backend, and APPENDS THEIR RECORDS TO THE COMMITTED ONES in docs/records/
# (OXYGEN_RECORD_DIR=docs/records; tests/support/record.rs):
#
#   shadow_cascades_tests.jsonl  tests/shadow_cascades.rs
#       shadow_map_resolution_trades_edge_error: docs/performance.md, the
#       shadow map's edge error by resolution
#   reference_view_tests.jsonl   tests/reference_view.rs, one record per
#       test: docs/accuracy.md, "Tests of the tracer" (measured figures and
#       the tolerances they are checked against)
#   gltf_fuzz_corpus_tests.jsonl tests/gltf_fuzz_corpus.rs: docs/security.md,
#       the importer's mutant corpus (imports, outcomes, slowest, peak heap)
#   frame_economy_tests.jsonl    tests/frame_economy.rs
#       rg11b10_hdr_stays_within_its_documented_error_and_shows_coarser_steps:
#       docs/performance.md, the packed HDR format's error (worst relative
#       error, pixels differing on screen, distinct levels per channel)
#   msaa_tests.jsonl             tests/msaa.rs
#       more_samples_bring_edges_closer_to_the_supersampled_picture:
#       docs/performance.md, MSAA's edge error against a supersampled render
#   probes_tests.jsonl           tests/probes.rs
#       a_parallax_box_puts_a_rooms_reflections_where_the_reference_sees_them:
#       docs/accuracy.md, a probe's error with and without its parallax box
#   gpu_visibility_tests.jsonl   tests/gpu_visibility.rs
#       occlusion_culling_never_drops_a_visible_object_along_a_camera_path:
#       docs/performance.md, what the GPU visibility paths keep against what
#       an ID render shows
#
#   scripts/test-records.sh [CARGO TEST ARGS..]
#   TEST_RECORDS_ONLY="msaa frame_economy" scripts/test-records.sh   # only those binaries' tests
#
# The backend is wgpu's pick, or WGPU_BACKEND (vulkan, gl); the docs' figures
# are lavapipe's (Mesa's software Vulkan): WGPU_BACKEND=vulkan on a machine
# with no other Vulkan adapter. A test that fails writes no record, and the
# script fails. Each record file must grow by one line per test named (its
# line count is taken before and after): a test that wrote nothing (renamed,
# so that `--exact` matched no test and cargo still exited 0; skipped on this
# adapter) fails the script too, naming the file. Review the new lines
# (`git diff docs/records`), copy their figures into the docs, and commit
# both; to try it without touching the committed records, set
# OXYGEN_RECORD_DIR to another folder first.
set -euo pipefail
cd "$(dirname "$0")/.."

export OXYGEN_RECORD_DIR=${OXYGEN_RECORD_DIR:-docs/records}
say() { printf '[test-records] %s\n' "$*" >&2; }
say "records go to $OXYGEN_RECORD_DIR (WGPU_BACKEND=${WGPU_BACKEND:-unset})"
cargo_args=("$@")

# The number of lines of $OXYGEN_RECORD_DIR/FILE, 0 when it is missing.
lines_of() {
  local file="$OXYGEN_RECORD_DIR/$1"
  if [ -f "$file" ]; then wc -l <"$file"; else echo 0; fi
}

# The binaries below; TEST_RECORDS_ONLY (names separated by spaces) runs
# some of them only.
binaries=" shadow_cascades reference_view probes gltf_fuzz_corpus frame_economy msaa gpu_visibility "
for only in ${TEST_RECORDS_ONLY:-}; do
  case "$binaries" in
    *" $only "*) ;;
    *) say "TEST_RECORDS_ONLY names $only: not one of$binaries"; exit 2 ;;
  esac
done

# recorded_tests BINARY TEST..: runs the named tests of tests/BINARY.rs
# (each writes one record to BINARY_tests.jsonl) and fails, naming the file,
# unless that file grew by exactly one line per test. Nothing when
# TEST_RECORDS_ONLY leaves BINARY out.
recorded_tests() {
  local binary=$1
  shift
  if [ -n "${TEST_RECORDS_ONLY:-}" ] && [[ " $TEST_RECORDS_ONLY " != *" $binary "* ]]; then
    return 0
  fi
  say "tests/$binary.rs"
  local file="${binary}_tests.jsonl" before after
  before=$(lines_of "$file")
  cargo test --locked "${cargo_args[@]}" --test "$binary" -- --exact "$@"
  after=$(lines_of "$file")
  if [ $((after - before)) -ne $# ]; then
    say "FAIL: $OXYGEN_RECORD_DIR/$file grew by $((after - before)) record(s), expected $# (one per test named):" \
      "a test renamed (--exact matched nothing) or skipped on this adapter?"
    exit 1
  fi
}

recorded_tests shadow_cascades \
  shadow_map_resolution_trades_edge_error

recorded_tests reference_view \
  a_white_furnace_returns_the_environment_times_the_brdf_albedo \
  the_error_falls_as_one_over_the_square_root_of_the_samples \
  an_emissive_square_lights_a_plane_as_the_closed_form_says \
  the_raster_view_and_its_traced_reference_agree_on_direct_light \
  the_reference_is_lit_by_the_renderer_environment \
  image_based_lighting_against_the_traced_reference \
  the_raster_model_reads_the_environment_as_the_raster_does \
  skinned_and_morphed_meshes_are_traced_in_their_pose \
  a_plane_seen_at_a_grazing_angle_reflects_as_the_brdf_says \
  the_reference_traces_sun_shadows

recorded_tests probes \
  a_parallax_box_puts_a_rooms_reflections_where_the_reference_sees_them

# CPU only: the importer's mutant corpus.
recorded_tests gltf_fuzz_corpus \
  every_mutant_of_the_shipped_scenes_ends_in_ok_or_a_clear_error_within_time_and_memory_budgets

recorded_tests frame_economy \
  rg11b10_hdr_stays_within_its_documented_error_and_shows_coarser_steps

recorded_tests msaa \
  more_samples_bring_edges_closer_to_the_supersampled_picture

recorded_tests gpu_visibility \
  occlusion_culling_never_drops_a_visible_object_along_a_camera_path

say "done: git diff $OXYGEN_RECORD_DIR"

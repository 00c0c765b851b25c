#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Runs every libFuzzer target for a while, one after another, and says what each found.
#
#   fuzz/run.sh [--merge] [MINUTES] [TARGET...]
#
# MINUTES per target (default 10; a fraction is fine: 0.5). TARGET names (fuzz_read_stl, ...,
# fuzz_manifest, fuzz_seg, fuzz_names, fuzz_regions) pick some; the default is all of them.
# Builds build/fuzz (clang, -fsanitize=fuzzer) first when it is missing or stale, with
# OSTEON_FUZZ_JOBS parallel jobs (default 2). Each target grows its own work corpus,
# build/fuzz/corpus-<target>, from the checked-in seeds in fuzz/corpus/<name>/ (read only); with
# --merge, what it found is minimised into fuzz/corpus/<name>/ afterwards (-merge=1: only inputs
# that add coverage are copied). Findings go to build/fuzz/artifacts/<target>-crash-<sha1> (or
# -timeout-, -oom-, -leak-); the script exits 1 when a run left any. One target at a time.
set -u -o pipefail

cd "$(dirname "$0")/.."
root=$(pwd)
build="${OSTEON_FUZZ_BUILD:-build/fuzz}"
jobs="${OSTEON_FUZZ_JOBS:-2}"

merge=0
minutes=10
picked=()
for arg in "$@"; do
  case "$arg" in
    --merge) merge=1 ;;
    -h | --help)
      sed -n '3,14p' "$0" | sed 's/^# \{0,1\}//'
      exit 0
      ;;
    fuzz_*) picked+=("$arg") ;;
    *[!0-9.]* | '')
      echo "fuzz/run.sh: error: '$arg' is neither MINUTES, --merge nor a fuzz_ target" >&2
      exit 2
      ;;
    *) minutes="$arg" ;;
  esac
done
seconds=$(awk -v m="$minutes" 'BEGIN { s = int(m * 60 + 0.5); print (s < 1 ? 1 : s) }')

# target  corpus folder  -max_len. Lengths stay below the corpus's 4 KB a file: a binary STL of
# 80 triangles, 2 KB of OFF or .seg (a few hundred faces), 4 KB of everything else (a NIfTI
# header with a few thousand voxels, a manifest of a few parts, a names file or the three
# ontology tables of a few dozen rows).
targets=(
  "fuzz_read_stl      stl      4084"
  "fuzz_read_obj      obj      4095"
  "fuzz_read_ply      ply      4095"
  "fuzz_read_off      off      2048"
  "fuzz_read_vtk      vtk      4095"
  "fuzz_read_gltf     gltf     4095"
  "fuzz_read_glb      glb      4095"
  "fuzz_decode        ostm     4095"
  "fuzz_manifest      manifest 4095"
  "fuzz_seg           seg      2048"
  "fuzz_names         names    4095"
  "fuzz_regions       regions  4095"
  "fuzz_volume_nii    nii      4095"
  "fuzz_volume_niigz  niigz    4095"
  "fuzz_volume_nrrd   nrrd     4095"
  "fuzz_volume_nhdr   nhdr     4095"
)

run=()
for entry in "${targets[@]}"; do
  read -r target _ _ <<<"$entry"
  if [ ${#picked[@]} -eq 0 ] || [[ " ${picked[*]} " == *" $target "* ]]; then run+=("$entry"); fi
done
for target in "${picked[@]}"; do
  if ! printf '%s\n' "${targets[@]}" | grep -q "^$target "; then
    echo "fuzz/run.sh: error: no target $target" >&2
    exit 2
  fi
done

# ---- build ---------------------------------------------------------------------------------
if [ ! -f "$build/build.ninja" ]; then
  CC=clang CXX=clang++ cmake -S . -B "$build" -G Ninja -DOSTEON_BUILD_FUZZ=ON \
    -DOSTEON_BUILD_TESTS=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo || exit 1
fi
names=()
for entry in "${run[@]}"; do
  read -r target _ _ <<<"$entry"
  names+=("$target")
done
cmake --build "$build" -j "$jobs" --target "${names[@]}" || exit 1

# ---- run -----------------------------------------------------------------------------------
mkdir -p "$build/artifacts" "$build/logs"
summary=()
findings=()
for entry in "${run[@]}"; do
  read -r target name max_len <<<"$entry"
  work="$build/corpus-$target"
  log="$build/logs/$target.log"
  mkdir -p "$work"
  before=$(find "$work" -type f | wc -l)
  artifacts_before=$(find "$build/artifacts" -name "$target-*" -type f | sort)
  echo "== $target: ${seconds}s, -max_len=$max_len, seeds fuzz/corpus/$name, log $log"
  "$build/$target" -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 \
    -max_len="$max_len" -print_final_stats=1 -artifact_prefix="$build/artifacts/$target-" \
    "$work" "fuzz/corpus/$name" >"$log" 2>&1
  rc=$?
  after=$(find "$work" -type f | wc -l)
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  new=$((after - before))
  found=$(comm -13 <(echo "$artifacts_before") \
    <(find "$build/artifacts" -name "$target-*" -type f | sort) | sed '/^$/d')
  count=$(printf '%s' "$found" | grep -c . || true)
  if [ "$rc" -ne 0 ] && [ "$count" -eq 0 ]; then
    # Killed or failed without an artifact (e.g. a bad flag): a finding all the same.
    found="$log (exit $rc)"
    count=1
  fi
  summary+=("$(printf '%-18s %10s %8s %6s %7s %5s %7s' "$target" "${execs:-?}" "${rate:-?}" \
    "${cov:-?}" "${ft:-?}" "$new" "$count")")
  if [ "$count" -gt 0 ]; then
    while IFS= read -r path; do findings+=("$target: $path"); done <<<"$found"
    grep -m1 -E '^(==[0-9]+==ERROR|.*runtime error|osteon fuzz:|SUMMARY)' "$log" | sed 's/^/    /'
  fi
  if [ "$merge" -eq 1 ]; then
    files_before=$(find "fuzz/corpus/$name" -type f | wc -l)
    "$build/$target" -merge=1 -rss_limit_mb=2048 -timeout=10 -max_len="$max_len" \
      "fuzz/corpus/$name" "$work" >"$build/logs/$target.merge.log" 2>&1 ||
      echo "    merge failed: $build/logs/$target.merge.log"
    files_after=$(find "fuzz/corpus/$name" -type f | wc -l)
    echo "    merged $((files_after - files_before)) inputs into fuzz/corpus/$name ($files_after files)"
    if [ "$files_after" -gt 40 ] && [ "$name" != ostm ]; then  # ostm: a plain coverage corpus
      echo "    fuzz/corpus/$name holds more than 40 files: keep one input per outcome: fuzz/distill.py $name"
    fi
  fi
done

echo
printf '%-18s %10s %8s %6s %7s %5s %7s\n' target executions exec/s cov ft new crashes
printf '%s\n' "${summary[@]}"
if [ ${#findings[@]} -gt 0 ]; then
  echo
  echo "findings (replay: $build/<target> <file>):"
  printf '  %s\n' "${findings[@]}"
  exit 1
fi

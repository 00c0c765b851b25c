#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Keeps one fuzzer-found input per outcome in fuzz/corpus/<name>/ (fuzz/README.md, "The corpus").

    fuzz/distill.py [--osteon build/release/osteon] [--dry-run] NAME...

`fuzz/run.sh --merge` copies every input that adds coverage into fuzz/corpus/<name>/, named by its
SHA-1: hundreds of files. This script runs each of them, and each file already there, through the
osteon CLI, takes the outcome (the error message without the file name, numbers and quoted text,
or "ok"), and keeps the largest new input of each outcome not yet pinned, renamed
found-<outcome>.<ext>; every other SHA-1-named input is removed. It never touches the named
files, and stops adding at the 40 files a folder may hold (it says which outcomes it left out).

NAME is a corpus folder whose inputs the CLI reads directly: stl obj ply off vtk gltf glb (read by
`osteon info`), nii niigz nrrd (`osteon info` of a label volume) and manifest (`osteon info` of a
folder holding it as manifest.json). Each run is bounded (10 s). The decoder's corpus/ostm is a
plain coverage corpus (SHA-1 names, replayed by the codec test) and is kept as merged.
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile

KMAX_FILES = 40
KSHA1 = re.compile(r"^[0-9a-f]{40}$")
# folder -> (file extension, how the CLI reads one input)
KFORMATS = {
    "stl": (".stl", "info"), "obj": (".obj", "info"), "ply": (".ply", "info"),
    "off": (".off", "info"), "vtk": (".vtk", "info"), "gltf": (".gltf", "info"),
    "glb": (".glb", "info"), "nii": (".nii", "info"), "niigz": (".nii.gz", "info"),
    "nrrd": (".nrrd", "info"), "manifest": (".json", "manifest"),
}


def outcome(osteon, path, ext, how, scratch):
    """The outcome of reading `path`: a slug of the CLI's error message, or "ok"."""
    work = os.path.join(scratch, "in")
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    if how == "manifest":
        target = work
        shutil.copyfile(path, os.path.join(work, "manifest.json"))
        command = [osteon, "info", target]
    else:
        target = os.path.join(work, "input" + ext)
        shutil.copyfile(path, target)
        command = [osteon, "info", target]
    try:
        run = subprocess.run(command, capture_output=True, text=True, errors="replace", timeout=10)
    except subprocess.TimeoutExpired:
        return "timeout"
    text = run.stderr
    match = re.search(r"osteon: error: (.*)", text)
    if run.returncode == 0 and not match:
        return "ok"
    message = match.group(1) if match else text.strip().splitlines()[-1] if text.strip() else ""
    message = message.replace(target, "").replace(work, "")
    message = re.sub(r'"[^"]*"|\'[^\']*\'', "", message)
    message = re.sub(r"[0-9]+", "", message).lower()
    slug = re.sub(r"[^a-z]+", "-", message).strip("-")
    return slug[:60].rstrip("-") or "error"


def distill(osteon, name, dry_run):
    folder = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus", name)
    ext, how = KFORMATS[name]
    files = sorted(os.listdir(folder))
    found = [f for f in files if KSHA1.match(f)]
    named = [f for f in files if not KSHA1.match(f)]
    if not found:
        print(f"{name}: no new inputs")
        return
    with tempfile.TemporaryDirectory() as scratch:
        pinned = {outcome(osteon, os.path.join(folder, f), ext, how, scratch) for f in named}
        best = {}  # outcome -> (size, file)
        for f in found:
            path = os.path.join(folder, f)
            key = outcome(osteon, path, ext, how, scratch)
            if key in pinned:
                continue
            size = os.path.getsize(path)
            if key not in best or size > best[key][0]:
                best[key] = (size, f)
    room = KMAX_FILES - len(named)
    kept, left = [], []
    for key in sorted(best):
        (kept if len(kept) < room else left).append(key)
    keep_files = {best[key][1] for key in kept}
    for key in kept:
        size, f = best[key]
        print(f"{name}: found-{key}{ext} ({size} bytes)")
        if not dry_run:
            os.rename(os.path.join(folder, f), os.path.join(folder, f"found-{key}{ext}"))
    for f in found:
        if f not in keep_files and not dry_run:
            os.remove(os.path.join(folder, f))
    print(f"{name}: {len(found)} merged inputs, {len(best)} new outcomes, kept {len(kept)}, "
          f"now {len(named) + len(kept)} files")
    for key in left:
        print(f"{name}: no room for outcome {key} (the folder holds {KMAX_FILES})")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--osteon", default="build/release/osteon")
    parser.add_argument("--dry-run", action="store_true")
    parser.add_argument("names", nargs="+", choices=sorted(KFORMATS))
    args = parser.parse_args()
    if not os.access(args.osteon, os.X_OK):
        print(f"fuzz/distill.py: error: {args.osteon}: not an executable osteon CLI", file=sys.stderr)
        return 2
    for name in args.names:
        distill(os.path.abspath(args.osteon), name, args.dry_run)
    return 0


if __name__ == "__main__":
    sys.exit(main())

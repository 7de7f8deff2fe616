#!/usr/bin/env python3
"""Runs clang-tidy on the given sources through build-tidy's compile commands, two at a time,
skipping every file that a run before found clean with the same preprocessed text.

Why by hand: clang-tidy has no cache of its own, and no tool in Debian adds one (the
ctcache-style wrappers are not packaged). A file's verdict depends only on its preprocessed
text (its headers included), the checks and clang-tidy's version, so those three are the key,
as ccache keys a compiler's object; preprocessing costs ~0.2 s a file against ~4 s to tidy it.
Only clean verdicts are kept (a file with findings is checked again until it is clean).

usage: tidy_run.py BUILD_DIR FILE...   (exit 0: no findings; 1: findings, printed)
Cache: $MLP_TIDY_CACHE, else $XDG_CACHE_HOME/mlprobe-tidy, else ~/.cache/mlprobe-tidy.
"""

import concurrent.futures
import hashlib
import json
import os
import re
import shlex
import subprocess
import sys

ROOT = os.path.realpath(os.path.join(os.path.dirname(__file__), ".."))


def cache_dir():
    if os.environ.get("MLP_TIDY_CACHE"):
        return os.environ["MLP_TIDY_CACHE"]
    base = os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache")
    return os.path.join(base, "mlprobe-tidy")


def preprocess_command(entry):
    """The file's compile command with -E in place of -c and the output on stdout."""
    args = entry.get("arguments") or shlex.split(entry["command"])
    out, skip = [], False
    for a in args:
        if skip:
            skip = False
            continue
        if a == "-o":
            skip = True
            continue
        out.append("-E" if a == "-c" else a)
    return out


def key_of(entry, salt):
    pre = subprocess.run(preprocess_command(entry), cwd=entry["directory"],
                         capture_output=True, check=False)
    if pre.returncode != 0:
        return None  # clang cannot parse it: tidy must run and report it
    # Paths relative to the checkout (its line markers and __FILE__s name it), so that a fresh
    # clone elsewhere (CI's) finds the verdicts this one left, as ccache's base_dir does.
    h = hashlib.sha256(salt)
    h.update(os.path.relpath(entry["file"], ROOT).encode())
    h.update(pre.stdout.replace(ROOT.encode(), b"<checkout>"))
    return h.hexdigest()


def tidy(build_dir, path):
    run = subprocess.run(["clang-tidy", "-p", build_dir, "--quiet", path],
                         capture_output=True, text=True, check=False)
    return run.stdout


def main():
    if len(sys.argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    build_dir, files = sys.argv[1], [os.path.abspath(f) for f in sys.argv[2:]]
    entries = {e["file"]: e for e in json.load(open(os.path.join(build_dir,
                                                                 "compile_commands.json")))}
    missing = [f for f in files if f not in entries]
    for f in missing:
        print(f"{f}: error: no compile command in {build_dir} (not built by CMake?)")
    version = subprocess.run(["clang-tidy", "--version"], capture_output=True, check=True).stdout
    config = open(os.path.join(ROOT, ".clang-tidy"), "rb").read()
    salt = version + config
    cache = cache_dir()
    os.makedirs(cache, exist_ok=True)
    jobs = int(os.environ.get("MLP_JOBS", "2"))
    checked = [f for f in files if f in entries]
    with concurrent.futures.ThreadPoolExecutor(jobs) as pool:
        keys = dict(zip(checked, pool.map(lambda f: key_of(entries[f], salt), checked)))
        todo = [f for f in checked
                if keys[f] is None or not os.path.exists(os.path.join(cache, keys[f]))]
        futures = {pool.submit(tidy, build_dir, f): f for f in todo}
        findings = []
        # Each verdict as it comes: a run cut short keeps what it finished.
        for done in concurrent.futures.as_completed(futures):
            f, report = futures[done], done.result()
            lines = [l for l in report.splitlines() if re.search(r": (warning|error):", l)]
            findings += lines
            if lines:
                print(report, end="", flush=True)
            elif keys[f] is not None:
                open(os.path.join(cache, keys[f]), "w").close()
    by_check = {}
    for l in findings:
        m = re.search(r"\[([^\],]+)[^\]]*\]$", l)  # [check] or [check,-warnings-as-errors]
        name = m.group(1) if m else "parse"
        by_check[name] = by_check.get(name, 0) + 1
    for name, n in sorted(by_check.items(), key=lambda kv: -kv[1]):
        print(f"{n:7d} {name}")
    print(f"tidy: {len(findings) + len(missing)} findings in {len(files)} files "
          f"({len(todo)} tidied, {len(checked) - len(todo)} clean before with the same "
          f"preprocessed text; cache {cache})")
    return 0 if not findings and not missing else 1


if __name__ == "__main__":
    sys.exit(main())

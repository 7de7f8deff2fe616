#!/usr/bin/python3
"""The module map as CMake has it (docs/DEVELOPING.md): each mlp library and program with the mlp
libraries it links directly, public or private (PRIVATE marked "(p)"), read from CMake's own
dependency graph of a configured build tree, not from the docs.

usage: scripts/module_map.py [BUILD_DIR] [--layers]   (default: build; configure it first)
exit: 0 printed, 2 no configured build tree there"""
import os, re, subprocess, sys, tempfile

build = next((a for a in sys.argv[1:] if not a.startswith("--")), "build")
if not os.path.isfile(os.path.join(build, "CMakeCache.txt")):
    print(f"module_map: {build} is not a configured build tree (run scripts/build.sh)", file=sys.stderr)
    sys.exit(2)
with tempfile.TemporaryDirectory() as tmp:
    dot = os.path.join(tmp, "deps.dot")
    subprocess.run(["cmake", f"--graphviz={dot}", "."], cwd=build, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    text = open(dot).read()
names, programs = {}, set()
for node, label, shape in re.findall(r'^\s*"?(node\d+)"?\s*\[\s*label\s*=\s*"([^"]+)",\s*shape\s*=\s*(\w+)',
                                     text, re.M):
    names[node] = label.split("\\n")[0]  # "mlp_base\n(mlp::base)": the target's own name
    if shape == "egg":
        programs.add(names[node])
links = {}
for a, b, attrs in re.findall(r'^\s*"?(node\d+)"?\s*->\s*"?(node\d+)"?\s*(\[[^\]]*\])?', text, re.M):
    links.setdefault(names[a], []).append((names[b], "dotted" in attrs))


def shown(target):  # libraries by their mlp:: name, programs as CMake names them
    return target if target in programs else "mlp::" + target[4:]


def ours(target):
    return target.startswith("mlp") and not target.startswith(("mlp_test", "test_"))


libraries = sorted(t for t in names.values() if ours(t) and t not in programs)
mine = {t: sorted((d, private) for d, private in links.get(t, []) if ours(d) and d not in programs)
        for t in names.values() if ours(t)}
depth = {}


def layer(t):  # 0 for a library that links none of ours, else one above its highest
    if t not in depth:
        depth[t] = 1 + max((layer(d) for d, _ in mine[t]), default=-1)
    return depth[t]


if "--layers" in sys.argv:
    print(f"{len(libraries)} libraries in layers: each links only libraries of the layers below")
    for k in range(max(map(layer, libraries)) + 1):
        print(f"{k:2d}  " + ", ".join(shown(t) for t in libraries if layer(t) == k))
    sys.exit(0)
rows = [(shown(t), [shown(d) + (" (p)" if private else "") for d, private in mine[t]])
        for t in sorted(mine, key=lambda t: (t in programs, t))]
width = max(len(t) for t, _ in rows)
print(f"{len(libraries)} libraries, {len(rows) - len(libraries)} programs (benchmarks and samples "
      "included); (p): linked privately")
for target, deps in rows:
    print(f"{target:<{width}}  {', '.join(deps) if deps else '-'}")

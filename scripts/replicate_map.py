#!/usr/bin/python3
"""A large prior map for the cost of localisation (docs/missions.md): COPIES copies of a map
folder's keyframes side by side (each shifted SHIFT m along x), written as a new map folder
(map.json with the keyframes' clouds, classes, graph, trajectory and hazards of the original;
only the keyframes are replicated). Identical copies make every answer ambiguous: it measures the
cost of an attempt, not its success.

  scripts/replicate_map.py MAP_DIR OUT_DIR COPIES [SHIFT]
"""
import json
import os
import shutil
import sys


_checksums = {}


def fnv1a(path):
    key = os.stat(path).st_ino  # the copies are hard links: one checksum per original
    if key not in _checksums:
        h = 0xcbf29ce484222325
        with open(path, "rb") as f:
            for b in f.read():
                h = ((h ^ b) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
        _checksums[key] = f"{h:016x}"
    return _checksums[key]


def main():
    src, out, copies = sys.argv[1], sys.argv[2], int(sys.argv[3])
    shift = float(sys.argv[4]) if len(sys.argv) > 4 else 60.0
    with open(os.path.join(src, "map.json")) as f:
        m = json.load(f)
    os.makedirs(os.path.join(out, "keyframes"), exist_ok=True)
    for name in ("classes.yaml", "graph.g2o", "trajectory.kitti", "hazards.json"):
        shutil.copy(os.path.join(src, name), out)
    keyframes, files = [], []
    for c in range(copies):
        for k in m["keyframes"]:
            k = dict(k)
            cloud = f"keyframes/{c:02d}-{os.path.basename(k['cloud'])}"
            os.link(os.path.join(src, k["cloud"]), os.path.join(out, cloud)) if not os.path.exists(os.path.join(out, cloud)) else None
            k["cloud"] = cloud
            k["pose"] = list(k["pose"])
            k["pose"][3] += c * shift
            keyframes.append(k)
    m["keyframes"] = keyframes
    for name in ["classes.yaml", "graph.g2o", "trajectory.kitti", "hazards.json"] + [k["cloud"] for k in keyframes]:
        p = os.path.join(out, name)
        files.append({"path": name, "bytes": os.path.getsize(p), "fnv1a": fnv1a(p)})
    m["files"] = files
    with open(os.path.join(out, "map.json"), "w") as f:
        json.dump(m, f)
    print(f"{len(keyframes)} keyframes in {out}")


if __name__ == "__main__":
    main()

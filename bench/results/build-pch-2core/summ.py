# The two clean builds' ninja logs (ninja_log-{before,after}.xz): wall time, the sum of every
# edge's time (two cores run two at once), and each precompiled header's compile time
import lzma


def load(path):
    rows = []
    for line in lzma.open(path, "rt"):
        if line.startswith("#"):
            continue
        start, end, _, name = line.split("\t")[:4]
        rows.append((int(start), int(end), name))
    return rows


for v in ("before", "after"):
    r = load(f"ninja_log-{v}.xz")
    wall = max(e for s, e, n in r) / 1000
    total = sum(e - s for s, e, n in r) / 1000
    pch = [(n.split("/")[0] + "/" + n.split("/")[2], (e - s) / 1000) for s, e, n in r if n.endswith(".gch")]
    print(f"{v}: {len(r)} edges, ninja's wall {wall:.0f} s, sum of edge times {total:.0f} s, "
          f"{len(pch)} PCHs: " + ", ".join(f"{n} {t:.1f} s" for n, t in pch))

# the objects of the targets that now reuse another's header compile as fast as with their own
# (a PCH GCC refused would leave them 1.5-2x slower, and -Winvalid-pch would warn in the logs)
before = {n: (e - s) / 1000 for s, e, n in load("ninja_log-before.xz")}
after = {n: (e - s) / 1000 for s, e, n in load("ninja_log-after.xz")}
for target in ("rl/CMakeFiles/bidex_rl.dir", "metarl/CMakeFiles/bidex_metarl.dir",
               "offline/CMakeFiles/bidex_offline.dir", "marl/CMakeFiles/bidex_marl.dir",
               "apps/CMakeFiles/bidex.dir", "tests/CMakeFiles/bidex_torch_tests.dir"):
    objs = [n for n in before if n.startswith(target + "/") and n.endswith(".o") and n in after]
    print(f"{target}: {len(objs)} objects, {sum(before[n] for n in objs):.0f} s before, "
          f"{sum(after[n] for n in objs):.0f} s after")

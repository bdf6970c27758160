#!/usr/bin/env bash
# fields.xdmf keeps its blocks' names at every output while interfaces move. It was one
# temporal collection of snapshots (a spatial collection of the meshes per time): ParaView
# 5.11's XDMF readers then named the blocks "dam[k]" and "ndam[k]" at the k-th output, and a
# block picked by name (Extract Block of /Root/ndam) was empty after t = 0 (checked with
# pvbatch on the lab chute's 31 outputs, session 40). Now the index holds one temporal
# collection per mesh; ParaView is not a CI dependency, so the structure itself is asserted:
# the Domain's children are temporal collections named after the meshes of fields.h5 (dam,
# ndam), each with one grid of that name per output time, at summary.json's output times, every
# referenced dataset present in fields.h5 with the declared shape.
source "$SRC/record_lib.sh"
rm -rf xdmf_blocks && mkdir xdmf_blocks && cd xdmf_blocks || exit 1
scene "$SRC/dynamic_gate_grows.xml" scene.xml -e 's|name="Interval" type="double" value="0.1"|name="Interval" type="double" value="0.05"|'
expect 0 "completed at t = 0.5 s" scene.xml
/usr/bin/python3 - gate_grows <<'PYEOF' || fail "fields.xdmf's structure (above)"
import json, sys, xml.etree.ElementTree as ET
import h5py
run = sys.argv[1]
dom = ET.parse(run + "/fields.xdmf").getroot().find("Domain")
series = dom.findall("Grid")
names = [g.get("Name") for g in series]
print("blocks:", names)
assert names == ["dam", "ndam"], names
with h5py.File(run + "/fields.h5", "r") as f:
    steps = sorted(f.keys())
    times = sorted(f[s].attrs["time"] for s in steps)
    for g in series:
        assert g.get("GridType") == "Collection" and g.get("CollectionType") == "Temporal", g.attrib
        members = g.findall("Grid")
        assert all(m.get("Name") == g.get("Name") for m in members), "a member renamed"
        t = [float(m.find("Time").get("Value")) for m in members]
        assert len(t) == len(times) and all(abs(a - b) < 1e-9 for a, b in zip(t, times)), (t, times)
        for m in members:
            for item in m.iter("DataItem"):
                # each snapshot's own file, relative to fields.xdmf, and the same data through
                # fields.h5's link
                name, path = item.text.split(":", 1)
                step = name.split("/")[-1][:-3]
                shape = tuple(int(v) for v in item.get("Dimensions").split())
                with h5py.File(run + "/" + name, "r") as s:
                    assert s[path].shape == shape, (name, path, s[path].shape, shape)
                assert f[step + path].shape == shape, (step, path)
n = json.load(open(run + "/summary.json"))["outputs"]["field_snapshots"]
assert n == len(times), (n, len(times))
moves = json.load(open(run + "/summary.json"))["solver_statistics"]["coupled"]["domain_manager"]["moves"]
print("outputs:", len(times), "moves:", moves)
assert moves >= 2, "the layout did not move: the check would not cover moves"
PYEOF
echo "xdmf blocks test passed"

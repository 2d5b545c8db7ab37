"""tools/perf_table.py: results recorded with their host, the table made from them, and the
table in docs/performance.md the one the committed records give (plain python3)."""

import io
import os
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
import perf_table  # noqa: E402
import harness  # noqa: E402

CPUINFO = """processor\t: 0
model name\t: AMD EPYC 9R14 96-Core Processor
flags\t\t: fpu sse2 avx2 avx512f
processor\t: 1
model name\t: AMD EPYC 9R14 96-Core Processor
flags\t\t: fpu sse2 avx2 avx512f
"""


def test_host_from_cpuinfo():
    info = perf_table.cpu_info(CPUINFO)
    assert info == ("AMD EPYC 9R14 96-Core Processor", "AVX-512", 2), info
    assert perf_table.host_slug(info) == "epyc-avx512-2cpu"
    avx2 = perf_table.cpu_info(CPUINFO.replace(" avx512f", "")
                               .replace("AMD EPYC 9R14", "Intel(R) Xeon(R)"))
    assert perf_table.host_slug(avx2) == "xeon-avx2-2cpu", perf_table.host_slug(avx2)


def test_record_keeps_bench_lines_only_with_provenance():
    lines = io.StringIO(
        "Blender 3.4.1 (hash)\n"
        '{"name": "blade_playback", "value": 30.5, "unit": "fps", '
        '"params": {"blender": "5.2.2 LTS"}}\n'
        "{not json\n"
        '{"name": "blade_playback_strand_frame", "value": 239, "unit": "us", "params": '
        '{"blender": "3.4.1", "ratio": 60.4}, "peer": "blender_particle_hair"}\n'
        '{"name": "blade_sim_1M", "value": 47.25, "unit": "ns per blade-step", "params": {}}\n')
    with tempfile.TemporaryDirectory() as d:
        path, n = perf_table.record(lines, d, perf_table.cpu_info(CPUINFO), "abc1234",
                                    "2026-12-03", 0.5)
        assert n == 3 and os.path.basename(path) == "epyc-avx512-2cpu.jsonl", (path, n)
        rows = perf_table.load_records(d)
        assert [r["name"] for r in rows] == ["blade_playback", "blade_playback_strand_frame",
                                             "blade_sim_1M"]
        assert rows[0]["blender"] == "5.2.2" and rows[2]["blender"] is None  # one row a release
        assert rows[1]["peer"] == "blender_particle_hair" and "peer" not in rows[0]
        assert all(r["host"] == "AMD EPYC 9R14 96-Core Processor, AVX-512, 2 vCPUs"
                   and r["commit"] == "abc1234" and r["load"] == 0.5 for r in rows)


def test_table_latest_line_targets_and_peer_ratio():
    base = {"params": {}, "host": "H, AVX-512, 2 vCPUs", "commit": "c1", "load": None,
            "source": "t"}
    recs = [dict(base, name="blade_sim_1M", value=60.0, unit="ns per blade-step", date="2026-12-01",
                 blender=None),
            dict(base, name="blade_sim_1M", value=39.5, unit="ns per blade-step", date="2026-12-03",
                 blender=None, commit="c2"),
            dict(base, name="blade_sim_1M", value=55000.0, unit="ns per blade-step",
                 date="2026-12-03",
                 blender=None, commit="c2", peer="blender_particle_hair"),
            dict(base, name="blade_sim_1M", value=151.0, unit="ns per blade-step",
                 date="2026-12-04", blender=None, commit="c3", host="E, AVX2 only, 2 vCPUs"),
            dict(base, name="blade_playback", value=26.0, unit="fps", date="2026-12-03",
                 blender="3.4.1"),
            dict(base, name="blade_playback", value=26.0, unit="fps", date="2026-12-03",
                 blender="5.2.2")]
    for i, r in enumerate(recs):
        r["_order"] = (r["date"], 0, "f", i)
    targets = {"blade_playback": {"target": ">= 24", "better": "higher",
                                  "by_blender": {"4": ">= 30", "5": ">= 30"}},
               "blade_sim_1M": {"target": "<= 40", "better": "lower"}}
    rows = perf_table.table(recs, targets).splitlines()[2:]
    # one line per name, Blender and vector width; the older 60 ns run is gone, and the
    # later AVX2-only host's line stands after the AVX-512 one instead of over it
    assert len(rows) == 4, rows
    assert rows[0].startswith("| `blade_playback` | 3.4.1 | ≥ 24 | **26 fps** |"), rows[0]
    assert "**26 fps** (misses)" in rows[1] and "| 5.2.2 | ≥ 30 |" in rows[1], rows[1]
    assert "**39.5 ns per blade-step** |" in rows[2] and "| c2 |" in rows[2], rows[2]
    assert "blender_particle_hair: 55,000 ns per blade-step (1,392×)" in rows[2], rows[2]
    assert "**151 ns per blade-step** (misses)" in rows[3] and "| E, AVX2 only" in rows[3], \
        rows[3]


def test_doc_table_is_what_the_records_give():
    with open(perf_table.DOC, encoding="utf-8") as f:
        text = f.read()
    new = perf_table.render_doc(text, perf_table.table(perf_table.load_records(),
                                                       perf_table.load_targets()))
    assert new == text, "docs/performance.md's table is stale: python3 tools/perf_table.py write"
    assert text.count("\n| `") >= 10, "the table lists fewer than ten benchmarks"
    for name in ("blade_sim_1M", "blade_playback", "tree_playback_50k", "picture_1080p"):
        assert f"| `{name}` |" in text, name


if __name__ == "__main__":
    sys.exit(harness.run(globals()))

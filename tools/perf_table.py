"""The performance record: benchmark results kept as data, and the one table made from them.

Results live in docs/perf/<host>.jsonl, one JSON object a line: the benchmark line of
DESIGN.md ({"name", "value", "unit", "params", "peer"?}) plus where and when it was measured:
"host" (the processor, its widest vector instructions and its CPU count, in words), "commit",
"date" (UTC, YYYY-MM-DD), "load" (1-minute load average when the run started, or null),
"blender" (the version string for benchmarks run in Blender, else null), "source" and an
optional "note". docs/perf/targets.json gives each headline its target. The table in
docs/performance.md (between the marker lines) is made from these files only, so that it
cannot disagree with them:

  python3 tools/perf_table.py record < lines      append ./build.sh bench's lines to this host
  python3 tools/perf_table.py write               remake the table in docs/performance.md
  python3 tools/perf_table.py check               exit 1 when the table is not what the data gives

Plain Python, no bpy and no third-party modules: ./build.sh runs it with the system Python."""

import datetime
import json
import os
import re
import subprocess
import sys

import generated_block

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PERF = os.path.join(ROOT, "docs", "perf")
DOC = os.path.join(ROOT, "docs", "performance.md")
BEGIN, END = "<!-- perf-table -->", "<!-- /perf-table -->"
KEYS = ("name", "value", "unit", "params", "host", "commit", "date", "load", "blender", "source")


# ---- this machine ----------------------------------------------------------------------------
def cpu_info(text=None):
    """(model name, widest vector extension, logical CPUs) from /proc/cpuinfo."""
    if text is None:
        with open("/proc/cpuinfo") as f:
            text = f.read()
    model = re.search(r"^model name\s*:\s*(.+)$", text, re.M)
    flags = re.search(r"^flags\s*:\s*(.+)$", text, re.M)
    flags = set(flags.group(1).split()) if flags else set()
    isa = next((n for f, n in (("avx512f", "AVX-512"), ("avx2", "AVX2"), ("sse2", "SSE2"))
                if f in flags), "no SIMD")
    cpus = len(re.findall(r"^processor\s*:", text, re.M)) or os.cpu_count() or 1
    return (re.sub(r"\s+", " ", model.group(1)).strip() if model else "unknown processor",
            isa, cpus)


def host_words(info=None):
    model, isa, cpus = info or cpu_info()
    return f"{model}, {isa}, {cpus} vCPUs"


def host_slug(info=None):
    """The file name of a host's records: the processor's family word, its widest vector
    extension and its CPU count ('epyc-avx512-2cpu')."""
    model, isa, cpus = info or cpu_info()
    words = re.findall(r"[a-z0-9]+", model.lower())
    family = next((w for w in words if w in ("epyc", "xeon", "ryzen", "core", "threadripper")),
                  words[0] if words else "cpu")
    return f"{family}-{re.sub(r'[^a-z0-9]', '', isa.lower())}-{cpus}cpu"


def git_commit():
    try:
        out = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short=7", "HEAD"], text=True,
                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL).stdout.strip()
        # (docs/ is left out: a run that records appends to docs/perf/ as it goes, and the
        # documents change nothing that is measured)
        dirty = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no",
                                "--", ".", ":(exclude)docs"],
                               text=True, stdout=subprocess.PIPE,
                               stderr=subprocess.DEVNULL).stdout.strip()
    except OSError:
        return None
    return (out + "+" if dirty else out) or None  # "+": the code differed from the commit


# ---- records -----------------------------------------------------------------------------------
def version(blender):
    """A Blender version string's numbers ("5.2.2 LTS" -> "5.2.2"), so that one release is one
    row whatever its build calls itself."""
    if not blender:
        return None
    m = re.match(r"\d+(\.\d+)*", str(blender).strip())
    return m.group(0) if m else str(blender)


def record(lines, out_dir=PERF, info=None, commit=None, today=None, load=None):
    """Appends every benchmark line among `lines` to this host's file; returns (path, count).
    Lines that are not a benchmark's JSON object are skipped (Blender prints other things)."""
    info = info or cpu_info()
    commit = commit if commit is not None else git_commit()
    today = today or datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d")
    if load is None and os.environ.get("TSK_BENCH_LOAD"):
        load = round(float(os.environ["TSK_BENCH_LOAD"]), 2)  # ./build.sh read it before the run
    if load is None:
        try:
            load = round(os.getloadavg()[0], 2)
        except OSError:
            load = None
    rows = []
    for line in lines:
        line = line.strip()
        if not line.startswith("{"):
            continue
        try:
            r = json.loads(line)
        except ValueError:
            continue
        if not isinstance(r, dict) or not {"name", "value", "unit"} <= r.keys():
            continue
        params = r.get("params") or {}
        out = {"name": r["name"], "value": r["value"], "unit": r["unit"], "params": params}
        if r.get("peer"):
            out["peer"] = r["peer"]
        out.update(host=host_words(info), commit=commit, date=today, load=load,
                   blender=version(params.get("blender")), source="./build.sh bench --record")
        rows.append(out)
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, host_slug(info) + ".jsonl")
    with open(path, "a") as f:
        for r in rows:
            f.write(json.dumps(r, ensure_ascii=False) + "\n")
    return path, len(rows)


def commit_times(commits):
    """{commit: its committer time} for the commits git knows (empty outside a clone)."""
    known = sorted({c.rstrip("+") for c in commits if c})
    if not known:
        return {}
    try:
        out = subprocess.run(["git", "-C", ROOT, "show", "-s", "--format=%h %ct", *known],
                             text=True, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    except OSError:
        return {}
    times = {}
    for line in out.stdout.splitlines():
        h, _, t = line.partition(" ")
        for c in known:
            if c.startswith(h) or h.startswith(c):
                times[c] = int(t)
    return times


def load_records(perf_dir=PERF):
    """Every record of every host, each with `_order`: its date, then the time of its commit
    (records of one day on several hosts are ordered by what was measured later), then its
    place in its file (a later line is a later run)."""
    out = []
    for fn in sorted(os.listdir(perf_dir)) if os.path.isdir(perf_dir) else []:
        if not fn.endswith(".jsonl"):
            continue
        with open(os.path.join(perf_dir, fn), encoding="utf-8") as f:
            for i, line in enumerate(f):
                if not line.strip():
                    continue
                r = json.loads(line)
                missing = [k for k in KEYS if k not in r]
                if missing:
                    raise ValueError(f"{fn}:{i + 1}: missing {', '.join(missing)}")
                r["_order"] = (r["date"], 0, fn, i)
                out.append(r)
    times = commit_times(r["commit"] for r in out)
    for r in out:
        r["_order"] = (r["date"], times.get((r["commit"] or "").rstrip("+"), 0)) + r["_order"][2:]
    return out


def load_targets(perf_dir=PERF):
    path = os.path.join(perf_dir, "targets.json")
    if not os.path.exists(path):
        return {}
    with open(path, encoding="utf-8") as f:
        return json.load(f)


# ---- the table ---------------------------------------------------------------------------------
def major(blender):
    return blender.split(".")[0] if blender else None


def target_of(targets, name, blender):
    t = targets.get(name)
    if not t:
        return None
    return (t.get("by_blender") or {}).get(major(blender) or "", t.get("target"))


def meets(target, value):
    m = re.match(r"\s*(<=|>=|<|>|=)\s*([-+0-9.eE]+)\s*$", target or "")
    if not m or not isinstance(value, (int, float)):
        return None
    op, lim = m.group(1), float(m.group(2))
    return {"<=": value <= lim, ">=": value >= lim, "<": value < lim, ">": value > lim,
            "=": value == lim}[op]


def fmt(v):
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return str(v)
    if v == 0 or abs(v) >= 100:
        return f"{v:,.0f}" if float(v).is_integer() or abs(v) >= 1000 else f"{v:,.1f}"
    return f"{v:.3g}"


def pretty_target(t):
    return (t or "—").replace("<=", "≤").replace(">=", "≥")


def vector_width(host):
    """The widest vector instructions a host's words name ("AVX-512", "AVX2"), or "" when
    they name none (hosts recorded before that was written down)."""
    return next((w for w in ("AVX-512", "AVX2") if w in (host or "")), "")


def table(records, targets):
    """The markdown table: per benchmark name, Blender (or native) and the host's widest
    vector instructions, the latest Tussock line; the peers measured in that same run beside
    it. (The processor behind this VM changes between sessions: an AVX2-only host's figure
    stands beside the AVX-512 host's, not over it.)"""
    own, peers = {}, {}
    for r in records:
        r["blender"] = version(r["blender"])
        key = (r["name"], r["blender"], vector_width(r["host"]))
        if r.get("peer"):
            # a peer run in Blender may stand beside a native line of the same run
            peers.setdefault((r["name"], r["host"], r["commit"], r["date"]), []).append(r)
        elif key not in own or r["_order"] >= own[key]["_order"]:
            own[key] = r
    order = list(targets)
    rows = sorted(own.values(), key=lambda r: (
        order.index(r["name"]) if r["name"] in order else len(order), r["name"],
        r["blender"] or "", vector_width(r["host"]) != "AVX-512", vector_width(r["host"])))
    out = ["| benchmark | Blender | target | value | peer (Tussock's lead) | host | commit | date"
           " | load |",
           "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        tgt = target_of(targets, r["name"], r["blender"])
        ok = meets(tgt, r["value"])
        value = f"{fmt(r['value'])} {r['unit']}"
        if ok is not None:
            value = f"**{value}**" + ("" if ok else " (misses)")
        better = (targets.get(r["name"]) or {}).get("better")
        ps = []
        run = peers.get((r["name"], r["host"], r["commit"], r["date"]), [])
        same = [p for p in run if p["blender"] == r["blender"]]
        for p in same or ([] if r["blender"] else run):
            txt = f"{p['peer']}: {fmt(p['value'])} {p['unit']}"
            if p["blender"] and p["blender"] != r["blender"]:
                txt += f" (Blender {p['blender']})"
            params = p.get("params") or {}
            ratio = params.get("ratio", params.get("ratio_to_tussock"))
            if ratio is None and p["unit"] == r["unit"] and better and r["value"] and p["value"]:
                ratio = p["value"] / r["value"] if better == "lower" else r["value"] / p["value"]
            if isinstance(ratio, (int, float)):
                txt += f" ({fmt(ratio)}×)"
            ps.append(txt)
        cells = [f"`{r['name']}`", r["blender"] or "native", pretty_target(tgt), value,
                 "; ".join(ps) or "—", r["host"], r["commit"] or "—", r["date"],
                 "—" if r["load"] is None else fmt(r["load"])]
        out.append("| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |")
    return "\n".join(out)


def render_doc(text, tbl):
    return generated_block.splice(text, BEGIN, END, tbl, DOC)


def main(argv):
    cmd = argv[1] if len(argv) > 1 else "check"
    if cmd == "record":
        path, n = record(sys.stdin)
        print(f"perf_table: {n} result(s) appended to {os.path.relpath(path, ROOT)}; "
              "run `python3 tools/perf_table.py write` to remake the table", file=sys.stderr)
        return 0
    if cmd not in ("write", "check"):
        print(__doc__, file=sys.stderr)
        return 2
    return generated_block.write_or_check(
        cmd, DOC, lambda text: render_doc(text, table(load_records(), load_targets())),
        "docs/performance.md: the table is not what docs/perf/*.jsonl gives; run "
        "`python3 tools/perf_table.py write`")


if __name__ == "__main__":
    sys.exit(main(sys.argv))

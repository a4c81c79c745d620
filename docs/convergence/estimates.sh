#!/usr/bin/env bash
# Regenerates the table of docs/error.md, "Checking the estimates": what renders say of their own
# error (estimated relative RMSE, coverage of the stated 95 % bound) against what the committed
# references measure, at 10, 100 and 1,000 iterations. Run from the repository root after
# `cargo build --release`; about 15 minutes on 2 cores. Writes target/estimates/.
#
# The six scenes at 1/16 of their resolution (the size of tests/references/), 50,000 light paths
# per iteration, four runs each. The two caustic scenes, which the path tracer cannot render, get
# hybrid references of 8,000 iterations first. Everything is the hybrid's (the default when the
# table was made, 2026-12-03, until 2026-12-07). volumetric-caustic is measured without its rows
# 0–6, where the tiny light seen directly makes one pixel the whole image's error.
set -euo pipefail
HAZE=${HAZE:-target/release/haze}
OUT=${OUT:-target/estimates}
mkdir -p "$OUT"
size() {
    sed -n 's/^resolution *= *\[ *\([0-9]*\) *, *\([0-9]*\) *\].*/\1 \2/p' "scenes/$1.toml" | head -1 |
        awk '{w = int($1 / 16 + 0.5); h = int($2 / 16 + 0.5); if (w < 8) w = 8; if (h < 8) h = 8; print w "x" h}'
}
for s in glass-caustic volumetric-caustic; do
    "$HAZE" render "scenes/$s.toml" --reference -n 8000 -p 50000 --seed 1000 --integrator hybrid \
        --resolution "$(size "$s")" -q -o "$OUT/ref-$s.exr"
done
for s in cornell-fog spotlight-fog cornell-cloud vdb-cloud glass-caustic volumetric-caustic; do
    ref=tests/references/$s.exr
    [ -f "$OUT/ref-$s.exr" ] && ref=$OUT/ref-$s.exr
    region=()
    [ "$s" = volumetric-caustic ] && region=(--region 0,7,63,35)
    "$HAZE" converge "scenes/$s.toml" --reference "$ref" --resolution "$(size "$s")" \
        -p 50000 -n 1000 -t 100000 --runs 4 --integrator hybrid "${region[@]}" -q -o "$OUT/$s"
done
# The table: per checkpoint, the measured relative RMSE (squared errors averaged over the runs,
# standard error from their spread), the estimated one, their ratio and the coverage range.
python3 - "$OUT" <<'PY'
import csv, math, sys
out = sys.argv[1]
for s in ["cornell-fog", "spotlight-fog", "cornell-cloud", "vdb-cloud", "glass-caustic",
          "volumetric-caustic"]:
    rows = list(csv.DictReader(open(f"{out}/{s}.csv")))
    for it in ["10", "100", "1000"]:
        at = [r for r in rows if r["iterations"] == it]
        k = len(at)
        m = [float(r["rel_rmse"]) ** 2 for r in at]
        e = [float(r["estimated_rel_rmse"]) ** 2 for r in at]
        c = [float(r["coverage"]) for r in at]
        mm, em = sum(m) / k, sum(e) / k
        se = math.sqrt(sum((x - mm) ** 2 for x in m) / (k - 1) / k) / (2 * math.sqrt(mm))
        print(f"| {s} | {it} | {100 * math.sqrt(mm):.2f} % ± {100 * se:.2f} % | "
              f"{100 * math.sqrt(em):.2f} % | {math.sqrt(em / mm):.2f} | "
              f"{100 * min(c):.1f} % – {100 * max(c):.1f} % |")
PY

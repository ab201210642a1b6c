#!/usr/bin/env bash
# Regenerates the docs' figures from the built programs on the shipped data (data/), and prints
# the numbers docs/method.md and the README's caption quote about them, so that a change of the
# estimator is followed by the figures and the quotes in one step:
#
#   bash scripts/build.sh && bash scripts/make_figures.sh
#
# Figure: docs/figures/wic20250514_relative_response.png (in the README and docs/method.md), the
# FGE's response relative to the LEMI-036 on the whole WIC day of 2025-05-14 with its gains as
# recorded (--no-pair-noise).
# Printed: the whole day's delay fit, the largest |gain - 1| in the band used and the group delay
# (rows of calibrate_records' report), every band's gain and phase, and Z's gains with the
# default reference-noise correction. test/ros/test_plot_calibration.py checks the quotes
# against the same runs.
set -euo pipefail
cd "$(dirname "$0")/.."
B="${B:-build/devel/lib/magnetometer_insitu_calibration}"
[ -x "$B/calibrate_records" ] || { echo "make_figures.sh: no $B/calibrate_records: build first (scripts/build.sh)" >&2; exit 1; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
pair=(--reference data/wic20250514_lemi036.sec.gz --test data/wic20250514_fge.sec.gz --intervals 4)

"$B/calibrate_records" "${pair[@]}" --no-pair-noise --json "$work/as_recorded.json" >"$work/as_recorded.txt"
"$B/calibrate_records" "${pair[@]}" --json "$work/default.json" >"$work/default.txt"
/usr/bin/python3 scripts/plot_calibration "$work/as_recorded.json" --view response \
  --title "WIC 2025-05-14: DTU FGE relative to LEMI-036, whole day" \
  -o docs/figures/wic20250514_relative_response.png >/dev/null
echo "wrote docs/figures/wic20250514_relative_response.png"

echo "--- whole record, --no-pair-noise (the figure); report rows, whole-record column last:"
grep -E '^(delay test-ref s|response \|gain-1\| max|response group delay s)' "$work/as_recorded.txt"
/usr/bin/python3 - "$work/as_recorded.json" "$work/default.json" <<'PY'
import json, sys
def whole(path):
    return json.load(open(path))["windows"][-1]
w, d = whole(sys.argv[1]), whole(sys.argv[2])
print("delay fit %.3f +- %.3f s; band used %.4g-%.4g Hz" % (w["delay_s"], w["delay_ci95_s"],
                                                        w["band_used_low_hz"], w["band_used_high_hz"]))
print("f Hz      gain x, y, z (+- 95 %)                    phase x, y, z deg")
for b in w["relative_response"]:
    print("%-9.4g %s   %s" % (b["frequency_hz"],
          "  ".join("%.2f +- %.2f" % (g, c) for g, c in zip(b["gain"], b["gain_ci95"])),
          " ".join("%6.1f" % p for p in b["phase_deg"])))
print("--- whole record, default (reference noise from the pair): %s" % d["reference_noise"])
for b in d["relative_response"]:
    if b["frequency_hz"] > 0.02:
        print("%-9.4g Z gain %.2f +- %.2f" % (b["frequency_hz"], b["gain"][2], b["gain_ci95"][2]))
PY

#!/usr/bin/env bash
# README command 1: installs what is missing (Debian packages only), builds, and runs the main
# job: the in-situ calibration of the real WIC pair of 2025-05-14 (LEMI-036 reference, DTU FGE
# test) in the paper's layout, four 6-hour intervals and the whole day, with the package's default
# estimator (the errors-in-variables correction takes the reference's noise as the pair identifies
# it above the band; docs/wic_result.md), and whether the four intervals agree within their
# intervals; then the figure of the parameters with their intervals, tolerance zones and verdicts.
set -eo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
bash scripts/build.sh
# Not rosrun: rosrun skips executables under <package>/build/, where this standalone build puts them.
build/devel/lib/magnetometer_insitu_calibration/calibrate_records \
  --reference data/wic20250514_lemi036.sec.gz --test data/wic20250514_fge.sec.gz \
  --intervals 4 --json build/wic20250514_calibration.json
echo "JSON report: build/wic20250514_calibration.json"
# The parameters with their 95 % intervals per 6-hour interval and for the day, the tolerance
# zones (INTERMAGNET 1-second standard by default) and each verdict, as the paper's Figures 5, 6.
/usr/bin/python3 scripts/plot_calibration build/wic20250514_calibration.json \
  -o build/wic20250514_parameters.png >/dev/null
echo "Figure: build/wic20250514_parameters.png"

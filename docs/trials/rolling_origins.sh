#!/bin/sh
# Which setting of `mtwin thermal fit --log` to recommend for the published
# split of the real record (fit on the whole shared file, predict the 20 % of
# the record after it): each setting fitted on the start of the shared file
# up to an origin and scored on the span after it, for three origins.
# docs/thermal.md, "Which setting for the published split", shows the table
# this prints. Not part of mtwin's tests; run from the repository's root:
#   sh docs/trials/rolling_origins.sh [path/to/mtwin]
set -eu
MTWIN=${1:-target/release/mtwin}
LOG=../shared/data/real/fl-thermal-first60.csv
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
DRIFT=ch1_um:Z,ch2_um:Z,ch3_um:Z,ch4_um:Z,ch5_um:Z
INPUTS=speed_rpm,speed_rpm:square,t1_c,t2_c,t3_c,t4_c,t5_c,t6_c,t7_c,t8_c,t9_c,t10_c,t11_c,t12_c,t13_c,t14_c,t15_c,t16_c
printf '%-10s %-44s %8s %8s %8s %8s %8s\n' origin setting ch1 ch2 ch3 ch4 ch5
# origin:end of the scored span, min (each origin 220 min into a heating
# run, as the end of the shared file is 220 min into the 5000 rev/min run;
# 1110: the split of docs/thermal.md's tables)
for span in 708:944 1188:1584 1110:1667; do
  origin=${span%:*}
  end=${span#*:}
  # the rows up to `end` min (t_s is the first column)
  awk -F, -v e="$end" 'NR == 1 || $1 / 60 <= e' "$LOG" > "$TMP/log.csv"
  for setting in "--folds 3" "--folds 3 --ambient auto" "--folds 2-6" \
      "--folds 2-6 --ambient auto" "--folds 2-6 --ambient auto --also-plain"; do
    # shellcheck disable=SC2086
    "$MTWIN" thermal fit --log "$TMP/log.csv" --drift "$DRIFT" --inputs "$INPUTS" \
      --period-min 1 --train-until-min "$origin" $setting --out "$TMP/m.toml" \
      --format json -q > "$TMP/doc.json" 2> "$TMP/err.txt" || { cat "$TMP/err.txt" >&2; exit 1; }
    python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
print("%-10s %-44s" % (sys.argv[2], sys.argv[3]) + "".join(" %8.3f" % c["mae"] for c in d["test"]["channels"]))
' "$TMP/doc.json" "$origin-$end" "$setting"
  done
done

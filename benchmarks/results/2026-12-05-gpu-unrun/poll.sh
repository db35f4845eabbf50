#!/bin/bash
# One polling call of a lease: wait up to 570 s for $1/done, print the tails of its logs, then pack what
# is there (top-level files, each run's config.json, logs and metrics; no checkpoints) into $OUT/$2.tgz,
# so that a machine lost later keeps this call's files. A file comes back only under 16 MiB, so a
# metrics.jsonl over 4 MiB travels as metrics_every50.jsonl: every 50th iteration and every evaluation.
# Run it from the repository root on the GPU, the third argument the longest wait in seconds (570 by
# default; less when the lease has less than the call's 600 s left, so the packing still runs):
#   bash benchmarks/results/2026-12-05-gpu-unrun/poll.sh /tmp/out_rest rest [570]
DIR=$1; NAME=$2; WAIT=${3:-570}
for _ in $(seq 1 $((WAIT / 10))); do [ -f "$DIR/done" ] && break; sleep 10; done
for log in "$DIR"/*.log; do echo "== $log"; tail -c 700 "$log"; echo; done
ls "$DIR"
cd "$DIR" || exit 1
find runs -name metrics.jsonl -size +4M 2>/dev/null | while read -r m; do
  python3 -c "
import json, sys
with open(sys.argv[1]) as f, open(sys.argv[2], 'w') as g:
    for line in f:
        row = json.loads(line)
        if row['iteration'] % 50 == 0 or row.get('return_mean_policy') is not None:
            g.write(line)
" "$m" "${m%.jsonl}_every50.jsonl"
done
{ find . -maxdepth 1 -type f; find runs -name config.json -o -name '*.log' -o -name 'metrics*.jsonl' -size -5M 2>/dev/null; } \
  | tar czf "$OUT/$NAME.tgz" -T - && ls -la "$OUT"

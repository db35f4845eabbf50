#!/bin/bash
# Wait up to $1 seconds for $D/done (default /tmp/out), print progress, then pack the small files of $D
# (logs, JSON, each run's config and metrics) into $OUT/results.tar.gz.
D=${D:-/tmp/out}; end=$((SECONDS + $1))
while [ ! -e $D/done ] && [ $SECONDS -lt $end ]; do sleep 5; done
for d in card noautotune; do [ -d $D/$d ] && mkdir -p $D/${d}_logs && cp $D/$d/*.log $D/${d}_logs/ 2>/dev/null; done
ls $D; tail -n 4 $D/*.log 2>/dev/null | cut -c1-300
cd $D && find . -maxdepth 2 -type f -not -path './card/*' -not -path './noautotune/*' -not -path './runs/*' > /tmp/list
find runs -name config.json -o -name metrics.jsonl -size -3M >> /tmp/list 2>/dev/null
tar czf $OUT/results.tar.gz -T /tmp/list && ls -la $OUT

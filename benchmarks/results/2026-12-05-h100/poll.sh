#!/bin/bash
# Wait up to $1 seconds for $2/done, print progress, then pack the small files of each folder named after it
# (logs, JSON, each run's config and metrics, the card runs' logs) into $OUT/NAME.tar.gz.
end=$((SECONDS + $1)); shift
while [ ! -e $1/done ] && [ $SECONDS -lt $end ]; do sleep 5; done
for D in "$@"; do
  [ -d $D ] || continue; cd $D
  for d in card noautotune; do [ -d $d ] && mkdir -p ${d}_logs && cp $d/*.log ${d}_logs/ 2>/dev/null; done
  ls; tail -n 3 *.log 2>/dev/null | cut -c1-300
  find . -maxdepth 2 -type f -not -path './card/*' -not -path './noautotune/*' -not -path './runs/*' > /tmp/list
  find runs -name config.json -o -name metrics.jsonl -size -3M >> /tmp/list 2>/dev/null
  tar czf $OUT/$(basename $D).tar.gz -T /tmp/list
done
ls -la $OUT

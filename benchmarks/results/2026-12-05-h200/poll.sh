#!/bin/bash
# Wait up to $1 seconds for /tmp/out/done, print progress, then pack the small files of /tmp/out
# (logs, JSON, each run's config and metrics) into $OUT/results.tar.gz.
D=${D:-/tmp/out}; end=$((SECONDS + $1))
while [ ! -e $D/done ] && [ $SECONDS -lt $end ]; do sleep 10; done
[ -d $D/card ] && cp $D/card/*.log $D/ 2>/dev/null
ls $D; tail -n 3 $D/*.log 2>/dev/null | cut -c1-400
cd $D && find . -maxdepth 1 -type f > /tmp/list && find runs -name config.json -o -name metrics.jsonl >> /tmp/list 2>/dev/null
tar czf $OUT/results.tar.gz -T /tmp/list --exclude="*.ckpt*" && ls -la $OUT

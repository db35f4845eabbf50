#!/bin/bash
# A short lease's plan: the card's command in card.sh's short form (one bare run, three warm runs, one bare
# run without XLA's GPU autotuning) into /tmp/outc, then the HalfCheetah and Reacher experiments of
# ../2026-12-05-h200b/run.sh into /tmp/out35. Started with setsid, polled with poll2.sh.
here=$(dirname $0)
SHORT=1 D=/tmp/outc bash $here/card.sh
D=/tmp/out35 bash $here/../2026-12-05-h200b/run.sh

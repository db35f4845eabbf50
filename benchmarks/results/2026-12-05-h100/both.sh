#!/bin/bash
# A short lease's plan: the card's command in card.sh's short form (one bare run, three warm runs, one bare
# run without XLA's GPU autotuning) into /tmp/outc, then suite_1m.sh's HalfCheetah and Reacher experiments
# into /tmp/out35. Started with setsid; `poll.sh SECONDS /tmp/out35 /tmp/outc` waits and packs both.
here=$(dirname $0)
SHORT=1 D=/tmp/outc bash $here/card.sh
D=/tmp/out35 bash $here/suite_1m.sh

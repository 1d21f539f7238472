#!/bin/sh
# saccade run stopped by a signal: a clean stop (the stats print), then exit
# status 128 + the signal. Usage: signal.sh SACCADE GRAPH LOG INT|TERM
saccade=$1 graph=$2 log=$3 sig=$4
rm -f "$log"
"$saccade" run "$graph" --stats=0.1 >"$log.out" 2>"$log" &
pid=$!
# The handler is in place before the first periodic stats table appears.
tries=0
until grep -q "stats after" "$log" 2>/dev/null; do
  tries=$((tries + 1))
  if [ $tries -gt 600 ]; then echo "saccade printed no stats"; kill -9 $pid; exit 1; fi
  sleep 0.1
done
kill -"$sig" $pid
wait $pid
echo "exit status $?"
tail -n 1 "$log"
grep -c "^sink " "$log.out" | sed 's/^/final stats tables: /'

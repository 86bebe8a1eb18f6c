# Lease 33 (issue 39, item 4): where the MT20 pack's step goes at 16,384 slots. Runs in /root/src
# after its build (bench/lease_run.sh then). Everything lands in /root/t; the waiting calls pack
# it into $OUT. Nothing else runs beside a timed measurement.
export CUDA_VISIBLE_DEVICES=0
B=build-gpu/apps/bidex
T=/root/t
mkdir -p $T/warm
echo "$(date -u +%T) kernel cache warm-up: each task's scene at 256 worlds, side by side"
for task in hand_over catch_underarm catch_over2underarm catch_abreast two_catch_underarm \
    lift_underarm door_open_outward door_close_inward door_open_inward door_close_outward \
    bottle_cap push_block swing_cup scissors re_orientation pen switch grasp_and_place \
    block_stack pour_water; do
  $B bench warp --task $task --worlds 256 --seconds 0.2 --rounds 1 --determinism-steps 0 \
    --out $T/warm/$task.json > $T/warm-$task.log 2>&1 &
  sleep 1
done
wait
echo "$(date -u +%T) warm-up ended: $(ls $T/warm | wc -l) of 20 JSONs"
echo "$(date -u +%T) the pack, untraced"
$B bench pack --suite MT20 --slots 16384 --device cuda --seconds 2 --rounds 1 \
  --out $T/pack-plain.json > $T/pack-plain.log 2>&1
echo "$(date -u +%T) ended (exit $?)"; touch $T/plain.done
echo "$(date -u +%T) the pack, traced"
bench/kernel_trace.sh run /root/kt/libkt.so $T/trace.txt -- \
  $B bench pack --suite MT20 --slots 16384 --device cuda --seconds 2 --rounds 1 \
  --out $T/pack-traced.json > $T/pack-traced.log 2>&1
echo "$(date -u +%T) ended (exit $?)"
python3 bench/kernel_trace.py $T/trace.txt --bench $T/pack-traced.json --out $T/analysis \
  > $T/analysis.log 2>&1
echo "$(date -u +%T) analysis (exit $?)"
xz -T16 -6 -k $T/trace.txt
echo "$(date -u +%T) trace compressed: $(du -h $T/trace.txt.xz | cut -f1)"; touch $T/traced.done
echo "$(date -u +%T) one scene alone at the pack's world counts, untraced"
$B bench warp --task hand_over,door_open_outward --worlds 819,3276,16384 --seconds 2 \
  --rounds 1 --determinism-steps 0 --out $T/warp-worlds.json > $T/warp-worlds.log 2>&1
echo "$(date -u +%T) ended (exit $?)"; touch $T/chain.done

# Lease 33, second machine (the first went back while idle): twenty backends of one scene
# against one backend of it, in one run (bench pack with same20.yaml), after hand_over's kernels
# are compiled by an untimed warm-up.
export CUDA_VISIBLE_DEVICES=0
B=build-gpu/apps/bidex; T=/root/t; mkdir -p $T
echo "$(date -u +%T) warm-up"
$B bench warp --task hand_over --worlds 256 --seconds 0.2 --rounds 1 --determinism-steps 0 \
  --out $T/warm.json > $T/warm.log 2>&1
echo "$(date -u +%T) warm-up ended (exit $?)"
$B bench pack --suite bench/results/pack-trace-h200/same20.yaml --slots 16384 --device cuda \
  --seconds 2 --rounds 1 --out $T/pack-same20.json > $T/pack-same20.log 2>&1
echo "$(date -u +%T) same20 ended (exit $?)"; touch $T/done

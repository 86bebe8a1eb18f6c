# Lease 35 (issue 39): after lease 34's chain.sh finished seed 5's tf32 run and seed 6's pair on
# this machine, catch_abreast to 25M, tf32 (the YAML's defaults) then bf16 (-o ppo.bf16=true -o
# ppo.align_widths=true -o ppo.bf16_act=true), seeds SEEDS (default 3), 16,384 slots, 16
# minibatches, GPU 0, one run at a time; waits for WAIT (a file) first when it is set.
# Each run touches DIR/done when it ends; pack with
#   cd /root/t && find . -path '*/checkpoints/*' -prune -o -type f -print | tar -cJf $OUT/r.tar.xz -T -
export CUDA_VISIBLE_DEVICES=0
SHA=${BIDEX_COMMIT:-unknown}
B="-o ppo.bf16=true -o ppo.align_widths=true -o ppo.bf16_act=true"
[ -n "${WAIT:-}" ] && until [ -e "$WAIT" ]; do sleep 2; done
run() {  # $1 seed, $2 tf32/bf16
  d=/root/t/catch_abreast/$2-s$1
  extra=""; [ $2 = bf16 ] && extra="$B"
  cmd="bidex train --task catch_abreast --device cuda -o env.slots=16384 --run $d/catch_abreast-ppo-16384 --no-registry --time-limit 3000 -o ppo.minibatches=16 -o seed=$1 -o train.steps=25e6 $extra"
  mkdir -p $d; echo "commit $SHA: $cmd" > $d/command.txt
  echo "$(date -u +%T) start catch_abreast $2 s$1"
  BIDEX_COMMIT=$SHA build-gpu/apps/$cmd > $d/train.log 2>&1
  rc=$?
  echo "$(date -u +%T) end catch_abreast $2 s$1 (exit $rc)"; touch $d/done
}
for s in ${SEEDS:-3}; do for m in tf32 bf16; do run $s $m; done; done
echo "$(date -u +%T) lease35 chain done"

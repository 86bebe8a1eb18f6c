# Lease 34 (issue 39): is PPO's bfloat16 path a safe default? hand_over to 20M, seeds 3-6 (none
# of them run before), the YAML's defaults (TF32 products, "tf32") against -o ppo.bf16=true -o
# ppo.align_widths=true -o ppo.bf16_act=true ("bf16"), one build ($BIDEX_COMMIT), 16,384 slots,
# 16 minibatches, GPU 0, one run at a time. The first run compiles the machine's Warp kernels
# (no separate warm-up: the medians and the curves do not see it).
# SEEDS and MODES choose other seeds and settings (the lease lost its first machine and ran
# SEEDS=5 MODES=bf16 on a second one).
# Each run touches DIR/done when it ends; pack with
#   cd /root/t && find . -path '*/checkpoints/*' -prune -o -type f -print | tar -cJf $OUT/r.tar.xz -T -
export CUDA_VISIBLE_DEVICES=0
SHA=${BIDEX_COMMIT:-unknown}
B="-o ppo.bf16=true -o ppo.align_widths=true -o ppo.bf16_act=true"
mkdir -p /root/t
run() {  # $1 seed, $2 tf32/bf16
  d=/root/t/hand_over/$2-s$1
  extra=""; [ $2 = bf16 ] && extra="$B"
  cmd="bidex train --task hand_over --device cuda -o env.slots=16384 --run $d/hand_over-ppo-16384 --no-registry --time-limit 3000 -o ppo.minibatches=16 -o seed=$1 -o train.steps=20e6 $extra"
  mkdir -p $d; echo "commit $SHA: $cmd" > $d/command.txt
  echo "$(date -u +%T) start $2 s$1"
  BIDEX_COMMIT=$SHA build-gpu/apps/$cmd > $d/train.log 2>&1
  rc=$?
  echo "$(date -u +%T) end $2 s$1 (exit $rc)"; touch $d/done
}
for s in ${SEEDS:-3 4 5 6}; do for m in ${MODES:-tf32 bf16}; do run $s $m; done; done
echo "$(date -u +%T) chain done"; touch /root/chain.done

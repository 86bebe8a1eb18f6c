# Lease 32 (issue 39): FlatAdam's 64-element placement (2276e8d) measured. NEW ($BIDEX_COMMIT)
# against a6285c6 (OLD, built from old-a6285c6.tgz in /root/old), both with ppo.bf16,
# align_widths and bf16_act, 16,384 slots, 16 minibatches, GPU 0. catch_abreast first (the
# task whose bf16 weights sat 8 bytes off before the fix), then hand_over. The GPU machine's
# CPU tests build and run beside the untimed warm-up, before anything is timed.
# Each run touches DIR/done when it ends; pack with
#   cd /root/t && find . -path '*/checkpoints/*' -prune -o -type f -print | tar -cJf $OUT/r.tar.xz -T -
export CUDA_VISIBLE_DEVICES=0
NEWSHA=${BIDEX_COMMIT:-unknown}
S="-o ppo.bf16=true -o ppo.align_widths=true -o ppo.bf16_act=true"
mkdir -p /root/t/tests /root/tmp
until [ -f /root/old/build.end ]; do sleep 2; done
echo "$(date -u +%T) old build ended (exit $(cat /root/old/build.end))"
(cd /root/src && BIDEX_CMAKE_ARGS=-DBIDEX_RENDER_GL=NONE BIDEX_BUILD_TARGETS=bidex_torch_tests \
  scripts/offline-build.sh build /tmp/bidex-deps build-gpu > /root/t/tests-build.log 2>&1
  echo $? > /root/t/tests-build.end
  build-gpu/tests/bidex_torch_tests \
  "linear_gemm*,[flat_adam],PPO's bfloat16*,the actor-critic takes*,PPO with bias_grad_gemm*" \
  -s -r compact > /root/t/tests/gpu-machine-tests.log 2>&1
  echo "exit $?" >> /root/t/tests/gpu-machine-tests.log) &
tests=$!
# the machine's Warp kernels compiled once, before anything is timed
echo "$(date -u +%T) warm-up"
build-gpu/apps/bidex train --task hand_over --device cuda -o env.slots=16384 --run /root/tmp/warm \
  --no-registry -o train.steps=1 > /root/t/warmup.log 2>&1
echo "$(date -u +%T) warm-up ended (exit $?)"
wait $tests
echo "$(date -u +%T) tests ended: $(tail -1 /root/t/tests/gpu-machine-tests.log)"
BIDEX_COMMIT_OLD=a6285c6 BIDEX_COMMIT_NEW=$NEWSHA BIDEX_OLD_ARGS="$S" BIDEX_NEW_ARGS="$S" \
  BIDEX_COMPARE_STAGES=profile BIDEX_COMPARE_TASKS="catch_abreast hand_over" \
  BIDEX_COMPARE_TMP=/root/tmp \
  bench/learner_compare.sh run /root/t/profiles /root/old/build-gpu /root/src/build-gpu \
  > /root/t/profiles.log 2>&1
echo "$(date -u +%T) profiles ended"
run() {  # $1 task, $2 steps, $3 seed, $4 old/new
  if [ $4 = new ]; then tree=/root/src; sha=$NEWSHA; else tree=/root/old; sha=a6285c6; fi
  d=/root/t/$1/$4-s$3
  cmd="bidex train --task $1 --device cuda -o env.slots=16384 --run $d/$1-ppo-16384 --no-registry --time-limit 3000 -o ppo.minibatches=16 -o seed=$3 -o train.steps=$2 $S"
  mkdir -p $d; echo "commit $sha: $cmd" > $d/command.txt
  echo "$(date -u +%T) start $1 $4 s$3"
  (cd $tree && BIDEX_COMMIT=$sha build-gpu/apps/$cmd > $d/train.log 2>&1)
  echo "$(date -u +%T) end $1 $4 s$3 (exit $?)"; touch $d/done
}
for s in 0 1; do run catch_abreast 25e6 $s new; run catch_abreast 25e6 $s old; done
for s in 0 1 2; do run hand_over 20e6 $s new; run hand_over 20e6 $s old; done
echo "$(date -u +%T) chain done"; touch /root/chain.done

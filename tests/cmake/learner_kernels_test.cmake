# bench/learner_kernels.py (issue 39: the kernels of PPO's act and minibatch steps) without a GPU:
# --help says what it writes, a missing --out is refused, and a machine without PyTorch or a
# CUDA device gets a line saying which, with nothing written. Run with -DSRC=... -DWORK=...
# -DPYTHON=... (the GPU measurement itself: bench/results/learner-equiv-h200x2/lease27/kernels/).
include(${CMAKE_CURRENT_LIST_DIR}/script_checks.cmake)
set(script ${SRC}/bench/learner_kernels.py)
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})

run_script(help TRUE ${PYTHON} ${script} --help)
expect_text(help "learner-kernels.json" "--slots" "--obs" "--minibatches")

run_script(no_out FALSE ${PYTHON} ${script} --slots 64)
expect_text(no_out "--out")

run_script(no_gpu FALSE ${CMAKE_COMMAND} -E env CUDA_VISIBLE_DEVICES=
           ${PYTHON} ${script} --out ${WORK}/out)
string(FIND "${out_no_gpu}" "learner_kernels: PyTorch is not installed" no_torch)
string(FIND "${out_no_gpu}" "learner_kernels: no CUDA device" no_cuda)
if(no_torch EQUAL -1 AND no_cuda EQUAL -1)
  message(SEND_ERROR "no_gpu: neither 'PyTorch is not installed' nor 'no CUDA device':\n${out_no_gpu}")
endif()
if(EXISTS ${WORK}/out/learner-kernels.json OR EXISTS ${WORK}/out/learner-kernels.txt)
  message(SEND_ERROR "no_gpu: a refused run wrote files in ${WORK}/out")
endif()

#!/usr/bin/env bash
# A/B clean builds: before = HEAD's cmake (c74f47a), after = the working tree's change, each in a
# fresh copy, ccache off, one after the other on this machine
set -u
cd /tmp/pchab
for v in before after; do
  rm -rf src-$v && mkdir src-$v
  if [ $v = before ]; then git -C /work/main archive HEAD | tar -C src-$v -xf -
  else (cd /work/main && git ls-files -z | tar --null -T - -cf -) | tar -C src-$v -xf -; fi
  ln -s /work/main/.venv src-$v/.venv
  t0=$(date +%s)
  (cd src-$v && CCACHE_DISABLE=1 cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release > ../cmake-$v.log 2>&1 &&
   CCACHE_DISABLE=1 cmake --build build > ../build-$v.log 2>&1)
  echo "$v rc=$? seconds=$(( $(date +%s) - t0 ))" >> times.txt
  cp src-$v/build/.ninja_log ninja_log-$v
done

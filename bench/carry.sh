#!/usr/bin/env bash
# Files carried from one GPU lease to a later one: a device call brings back at most 64 MiB and
# carries at most 64 MiB with the working tree, so a folder goes as tar parts with a checksum
# file (bench/sweep_run.sh keep and bring, bench/lease_run.sh keep-cache and build):
#   bench/carry.sh out NAME DIR WORK DEST [FIRST [COUNT]] [-- PATH...]
#       DIR's files (or only the PATHs, relative to DIR) as WORK/NAME.tar.partNN of
#       $CARRY_PART_SIZE (default 15M) and WORK/NAME.sha256, made once (a later call with the
#       same WORK takes further parts from it); parts FIRST.. (default 0), COUNT of them (default
#       all), and the checksum file, copied to DEST
#   bench/carry.sh in NAME PARTS DIR
#       checks PARTS/NAME.tar.part* against PARTS/NAME.sha256 (every part must be there) and
#       unpacks them into DIR
#   bench/carry.sh recut NAME PARTS SIZE
#       the parts in PARTS, checked as `in` checks them, cut again into parts of SIZE (split's
#       sizes: 25M) with a new NAME.sha256: `out`'s parts come back from a device call, at most
#       16 MiB a file, but go into a later call beside the tracked tree, where larger parts mean
#       fewer calls (the bundle's part size fits: scripts/offline-build.sh split prints it).
#       The old parts stay until the new ones are written and checked
set -uo pipefail
stage=${1:-}
if [[ -z "$stage" || "$stage" == -h || "$stage" == --help ]]; then
  sed -n '2,/^[^#]/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'
  exit 0
fi
# checked NAME PARTS: exits unless PARTS holds NAME.sha256 and every part it lists, unchanged
checked() {
  [[ -f $2/$1.sha256 ]] || { echo "carry: no $1.sha256 in $2" >&2; exit 1; }
  (cd "$2" && sha256sum -c --quiet "$1.sha256") ||
    { echo "carry: the parts in $2 do not match $1.sha256" >&2; exit 1; }
}
# joined NAME PARTS: the parts NAME.sha256 lists, in its order (not whatever else matches the
# name), as one stream
joined() { (cd "$2" && awk '{print $2}' "$1.sha256" | xargs cat); }
# cut_parts NAME DIR SIZE: standard input as DIR/NAME.tar.partNN of SIZE and their DIR/NAME.sha256
cut_parts() {
  split -b "$3" -d - "$2/$1.tar.part" && (cd "$2" && sha256sum "$1".tar.part* >"$1.sha256")
}
case "$stage" in
out)
  name=${2:?NAME}; dir=${3:?DIR}; work=$(realpath -m "${4:?WORK}"); dest=$(realpath -m "${5:?DEST}")
  shift 5
  first=0 count=1000000
  [[ $# -gt 0 && $1 != -- ]] && { first=$1; shift; }
  [[ $# -gt 0 && $1 != -- ]] && { count=$1; shift; }
  [[ $# -gt 0 && $1 == -- ]] && shift
  [[ -d $dir ]] || { echo "carry: no folder $dir" >&2; exit 1; }
  if [[ ! -f $work/$name.done ]]; then
    mkdir -p "$work"
    rm -f "$work/$name".tar.part* "$work/$name.sha256"
    if [[ $# -gt 0 ]]; then tar -C "$dir" -cf - -- "$@"; else tar -C "$dir" -cf - .; fi |
      cut_parts "$name" "$work" "${CARRY_PART_SIZE:-15M}" ||
      { echo "carry: packing $dir failed" >&2; exit 1; }
    touch "$work/$name.done"
  fi
  mkdir -p "$dest"
  ls "$work/$name".tar.part* | tail -n +$((first + 1)) | head -n "$count" | xargs -r cp -t "$dest"
  cp "$work/$name.sha256" "$dest/"
  echo "carry: $(ls "$work/$name".tar.part* | wc -l) parts in all of $name; in $dest:" \
    "$(cd "$dest" && ls "$name".tar.part* 2>/dev/null | tr '\n' ' ')"
  ;;
in)
  name=${2:?NAME}; parts=$(realpath -m "${3:?PARTS}"); dir=$(realpath -m "${4:?DIR}")
  checked "$name" "$parts"
  mkdir -p "$dir"
  joined "$name" "$parts" | tar -C "$dir" -xf - ||
    { echo "carry: unpacking $name into $dir failed" >&2; exit 1; }
  echo "carry: $name unpacked into $dir"
  ;;
recut)
  name=${2:?NAME}; parts=$(realpath -m "${3:?PARTS}"); size=${4:?SIZE}
  checked "$name" "$parts"
  new=$parts/.recut-$name old=$parts/.old-$name
  rm -rf "$new" "$old" && mkdir -p "$new" "$old" || exit 1
  joined "$name" "$parts" | cut_parts "$name" "$new" "$size" ||
    { echo "carry: cutting $name into parts of $size failed" >&2; rm -rf "$new" "$old"; exit 1; }
  [[ $(joined "$name" "$parts" | sha256sum) == "$(joined "$name" "$new" | sha256sum)" ]] ||
    { echo "carry: the new parts of $name differ from the old" >&2; rm -rf "$new" "$old"; exit 1; }
  # the old parts aside, the new ones in, the checksum file last
  (cd "$parts" && awk '{print $2}' "$name.sha256" | xargs mv -t "$old" && mv "$name.sha256" "$old/") &&
    mv "$new/$name".tar.part* "$parts/" && mv "$new/$name.sha256" "$parts/" ||
    { echo "carry: replacing the parts of $name failed; the old ones are in $old" >&2; exit 1; }
  rm -rf "$new" "$old"
  echo "carry: $name in $(awk 'END {print NR}' "$parts/$name.sha256") parts of at most $size in $parts"
  ;;
*)
  echo "carry: unknown stage $stage (out, in or recut)" >&2
  exit 2
  ;;
esac

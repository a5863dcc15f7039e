#!/usr/bin/env bash
# Run a command where `python3.13` exists (Blender 5.1 and newer embed Python 3.13, so their `bpy` module
# needs it). With a python3.13 on this machine the command simply runs here. Otherwise it runs in a Debian 13
# (trixie) root under .cache/py313-root, made once with debootstrap from Debian's package mirror (~2 minutes,
# ~1.5 GB) with python3.13, make and Blender's X/GL run-time libraries, and this checkout bind-mounted at the
# same path inside a private mount namespace (nothing stays mounted when the command ends).
#
# Usage: scripts/py313.sh <command> [args...]      e.g. scripts/py313.sh make _test BPY=5.2.3
#        scripts/py313.sh --which                  prints this machine's python3.13 (nothing if it has none)
# FH_PY313_FORCE_ROOT=1 uses the Debian 13 root even where a python3.13 exists (to test that path).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

native_python() {
  local candidate
  for candidate in "$(command -v python3.13 2>/dev/null || true)" /usr/bin/python3.13 /usr/local/bin/python3.13 \
                   "${PYENV_ROOT:-$HOME/.pyenv}"/versions/3.13*/bin/python3.13; do
    if [ -n "$candidate" ] && [ -x "$candidate" ] && "$candidate" -c 'import venv, ssl' >/dev/null 2>&1; then
      echo "$candidate"
      return 0
    fi
  done
  return 1
}

if [ "${FH_PY313_FORCE_ROOT:-0}" != 1 ] && native=$(native_python); then
  if [ "${1:-}" = --which ]; then echo "$native"; exit 0; fi
  exec "$@"
fi
[ "${1:-}" = --which ] && exit 0
if [ "$(id -u)" != 0 ]; then
  echo "error: no python3.13 on this machine, and making a Debian 13 root for it needs root" >&2
  exit 1
fi
root="${FH_PY313_ROOT:-$here/.cache/py313-root}"
mirror="${FH_DEBIAN_MIRROR:-$(sed -n 's/^URIs: *\(http[^ ]*debian\)$/\1/p' /etc/apt/sources.list.d/*.sources 2>/dev/null | head -n1)}"
mirror="${mirror:-http://deb.debian.org/debian}"
packages="python3.13 python3.13-venv make ca-certificates libx11-6 libxrender1 libxfixes3 libxi6 libxkbcommon0"
packages="$packages libsm6 libice6 libxext6 libxt6 libxxf86vm1 libgl1 libegl1 libgomp1"

if [ ! -e "$root/.fh-ready" ]; then
  echo "== making a Debian 13 root with Python 3.13 in $root (once; ~2 minutes)" >&2
  command -v debootstrap >/dev/null 2>&1 || { apt-get update -qq && apt-get install -y -qq debootstrap >/dev/null; }
  rm -rf "$root"
  mkdir -p "$root"
  debootstrap --variant=minbase trixie "$root" "$mirror" >"$root.log" 2>&1 || { tail -20 "$root.log" >&2; exit 1; }
  cp /etc/resolv.conf "$root/etc/resolv.conf"
  unshare --mount --propagation private bash -c "
    mount -t proc proc '$root/proc' && mount --rbind /dev '$root/dev'
    chroot '$root' /usr/bin/env DEBIAN_FRONTEND=noninteractive PATH=/usr/sbin:/usr/bin:/sbin:/bin \
      bash -c 'apt-get update -qq && apt-get install -y -qq --no-install-recommends $packages >/dev/null'
  " || { echo "error: installing python3.13 into $root failed" >&2; exit 1; }
  touch "$root/.fh-ready"
fi
cp /etc/resolv.conf "$root/etc/resolv.conf"
mkdir -p "$root$here" "$root/tmp"
script="/tmp/fh-command-$$.sh"
{
  for name in FH_ZIP PYTEST_ARGS TESTS FH_TEST_FROM_SOURCE; do
    [ -n "${!name:-}" ] && printf 'export %s=%q\n' "$name" "${!name}"
  done
  printf 'cd %q\n' "$here"
  printf '%q ' "$@"
  echo
} >"$root$script"
trap 'rm -f "$root$script"' EXIT
unshare --mount --propagation private bash -c "
  mount -t proc proc '$root/proc' && mount --rbind /dev '$root/dev' && mount --bind '$here' '$root$here' &&
  chroot '$root' /usr/bin/env -i PATH=/usr/local/bin:/usr/bin:/bin HOME=/root LANG=C.UTF-8 bash '$script'
"

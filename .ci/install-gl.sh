#!/usr/bin/env bash
# Headless OpenGL for MuJoCo rendering (EGL via Mesa, OSMesa as fallback), from Debian packages.
set -euo pipefail
need=(libegl1 libegl-mesa0 libgl1-mesa-dri libgles2 libosmesa6)
missing=()
for p in "${need[@]}"; do dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p"); done
[ ${#missing[@]} -eq 0 ] && exit 0
command -v apt-get >/dev/null || { echo "no apt-get: install EGL or OSMesa yourself" >&2; exit 1; }
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  # Never prompt for a password from make: only passwordless sudo is used.
  sudo -n true 2>/dev/null || { echo "not root: install ${missing[*]} to render" >&2; exit 1; }
  SUDO="sudo -n"
fi
# make run / make test call this: say what changes on the system before it does
echo "installing headless OpenGL for rendering with apt-get: ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}"

#!/usr/bin/env bash
# Headless Chromium (Debian's `chromium` package) for the test that opens `ariel view --web` in a
# real browser (tests/recording/test_view.py); without it that test skips and says why.
set -euo pipefail
dpkg -s chromium >/dev/null 2>&1 && exit 0
command -v apt-get >/dev/null || { echo "no apt-get: install Chromium yourself" >&2; exit 1; }
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  # Never prompt for a password: only passwordless sudo is used.
  sudo -n true 2>/dev/null || { echo "not root: install chromium to run the browser test" >&2; exit 1; }
  SUDO="sudo -n"
fi
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq chromium

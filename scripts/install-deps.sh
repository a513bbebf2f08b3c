#!/usr/bin/env bash
# Installs the Debian 12 packages owlcal needs to build, test and draw its figures.
set -euo pipefail
pkgs=(cmake g++ make pkg-config
      libopencv-dev libceres-dev libeigen3-dev libapriltag-dev libgtest-dev
      libyaml-cpp-dev nlohmann-json3-dev libcli11-dev gnuplot-nox
      python3-mrcal clang-format
      poppler-utils librsvg2-bin)   # pdftoppm / rsvg-convert: the printable-target tests rasterise PDF and SVG
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then echo "install-deps: all ${#pkgs[@]} packages present"; exit 0; fi
SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO=sudo
echo "install-deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"

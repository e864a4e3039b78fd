#!/bin/sh
# What the project venv (and so `make demo` and `make test`) needs from the system, checked before
# anything is downloaded or built. Run by the Makefile's venv target; safe to run by hand.
#
#   sh tools/check_system.sh [PYTHON]    prints the interpreter to use on stdout, messages on stderr
#
# Python: PYTHON if given, else python3.11 (bpy 4.2 LTS), else python3.13 (bpy 5.2): bpy has wheels
# for one Python version each (requirements-dev.txt picks bpy by python_version).
# It also needs, for that Python X.Y: venv with ensurepip (Debian: pythonX.Y-venv), the headers
# (Python.h: pythonX.Y-dev), the C compiler Python builds extensions with (gcc), and the X11/GL
# shared libraries that bpy links even in background mode.
#
# As root with apt-get (a fresh Debian/Ubuntu machine, a container, CI): whatever is missing is
# installed with apt-get (--no-install-recommends). Otherwise it prints the one command that
# installs it (sudo apt-get install ...) and stops. UNBOUND_NO_APT=1: never install, only check.
set -eu

say() { echo "check_system: $*" >&2; }

APT=
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1 && [ -z "${UNBOUND_NO_APT:-}" ]; then
	APT=1
fi

# pyver PY: "3.11" etc. if PY runs, else nothing.
pyver() {
	"$1" -c 'import sys; print("%d.%d" % sys.version_info[:2])' 2>/dev/null || :
}

apt_updated=
apt_update() {
	[ -z "$apt_updated" ] || return 0
	export DEBIAN_FRONTEND=noninteractive
	apt-get update -qq >&2 || { say "error: apt-get update failed"; exit 1; }
	apt_updated=1
}

# apt_has PKG: the package index knows PKG (refreshed first where we may install; false without apt).
apt_has() {
	[ -z "$APT" ] || apt_update
	command -v apt-cache >/dev/null 2>&1 && [ -n "$(apt-cache show --no-all-versions "$1" 2>/dev/null | head -n 1)" ]
}

apt_install() {
	say "installing with apt-get: $*"
	apt_update
	apt-get install -y -qq --no-install-recommends "$@" >/dev/null || { say "error: apt-get install $* failed"; exit 1; }
}

# stop WHAT PKGS: the final word when something is missing and will not be installed here.
stop() {
	what=$1
	pkgs=$2
	say "error: missing: $what"
	if command -v apt-get >/dev/null 2>&1; then
		say "install with:"
		echo >&2
		if [ "$(id -u)" = 0 ]; then
			echo "    apt-get update && apt-get install -y --no-install-recommends $pkgs" >&2
		else
			echo "    sudo apt-get update && sudo apt-get install -y --no-install-recommends $pkgs" >&2
		fi
		echo >&2
	else
		say "these are Debian/Ubuntu package names ($pkgs); install your distribution's equivalents"
	fi
	say "then run the make command again"
	exit 1
}

# -- Python 3.11 or 3.13 -----------------------------------------------------------------------------
PY=${1:-}
if [ -z "$PY" ]; then
	for p in python3.11 python3.13; do
		if [ -n "$(pyver "$p")" ]; then
			PY=$(command -v "$p")
			break
		fi
	done
fi
if [ -z "$PY" ]; then
	found=
	for p in python3 python3.12 python3.10; do
		v=$(pyver "$p")
		[ -z "$v" ] || { found="$found $p is $v;"; }
	done
	say "Unbound needs Python 3.11 (with bpy 4.2 LTS) or Python 3.13 (with bpy 5.2): bpy, Blender as a"
	say "Python module, has wheels for one Python version each.${found:+ Found:$found}"
	pkg=
	if apt_has python3.11; then pkg=python3.11; elif apt_has python3.13; then pkg=python3.13; fi
	if [ -n "$pkg" ] && [ -n "$APT" ]; then
		apt_install "$pkg" "$pkg-venv" "$pkg-dev"
		PY=$(command -v "$pkg")
	elif [ -n "$pkg" ]; then
		stop "$pkg" "$pkg $pkg-venv $pkg-dev"
	else
		say "error: no python3.11 or python3.13 here. Debian 12 has python3.11, Debian 13 python3.13; on"
		say "other releases (e.g. Ubuntu 24.04, whose python3 is 3.12) install one of them (e.g. from the"
		say "deadsnakes PPA), or run make with PYTHON=/path/to/python3.11 or python3.13"
		exit 1
	fi
fi
V=$(pyver "$PY")
case $V in
3.11 | 3.13) ;;
"") say "error: $PY does not run"; exit 1 ;;
*) say "error: $PY is Python $V; Unbound needs 3.11 (bpy 4.2) or 3.13 (bpy 5.2): make PYTHON=python3.11"; exit 1 ;;
esac

# -- venv, headers, compiler, bpy's libraries -------------------------------------------------------
missing=
pkgs=

# venv needs ensurepip to put pip into the venv; Debian ships it apart, in pythonX.Y-venv.
if ! "$PY" -c 'import ensurepip, venv, sys; sys.exit(not ensurepip.version())' >/dev/null 2>&1; then
	missing="$missing ensurepip (python -m venv);"
	pkgs="$pkgs python$V-venv"
fi
if ! "$PY" -c 'import os, sys, sysconfig; sys.exit(not os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")))' 2>/dev/null; then
	missing="$missing Python.h (the C headers of Python $V);"
	pkgs="$pkgs python$V-dev"
fi
# The compiler setuptools calls: $CC, else the one Python was built with (x86_64-linux-gnu-gcc on
# Debian, part of the gcc package).
cc=${CC:-$("$PY" -c 'import sysconfig; print(sysconfig.get_config_var("CC") or "cc")' 2>/dev/null || echo cc)}
cc=${cc%% *}
if ! command -v "$cc" >/dev/null 2>&1; then
	missing="$missing a C compiler ($cc);"
	pkgs="$pkgs gcc"
fi

# Shared libraries bpy's own libraries link against (ldd of bpy 4.2's __init__.so and of bpy 5.2's,
# with libusd_ms and MaterialX); bpy 5.x's compositor also opens libEGL in background mode.
LIBS="libX11.so.6:libx11-6 libXext.so.6:libxext6 libXrender.so.1:libxrender1 libXi.so.6:libxi6
	libXfixes.so.3:libxfixes3 libxkbcommon.so.0:libxkbcommon0 libSM.so.6:libsm6 libICE.so.6:libice6
	libXxf86vm.so.1:libxxf86vm1 libXt.so.6:libxt6 libGL.so.1:libgl1"
[ "$V" = 3.11 ] || LIBS="$LIBS libEGL.so.1:libegl1"
if command -v ldconfig >/dev/null 2>&1 || [ -x /sbin/ldconfig ]; then
	cache=$( (command -v ldconfig >/dev/null 2>&1 && ldconfig -p) || /sbin/ldconfig -p)
	libs=
	for pair in $LIBS; do
		so=${pair%%:*}
		pkg=${pair#*:}
		if ! printf '%s\n' "$cache" | grep -q "^[[:space:]]*$so "; then
			if [ "$pkg" = libxt6 ]; then
				# Renamed libxt6t64 in the 64-bit time_t transition (Debian 13, Ubuntu 24.04).
				if apt_has libxt6t64; then
					pkg=libxt6t64
				elif ! apt_has libxt6 && [ "$V" != 3.11 ]; then
					pkg=libxt6t64
				fi
			fi
			libs="$libs $so"
			pkgs="$pkgs $pkg"
		fi
	done
	[ -z "$libs" ] || missing="$missing X11/GL libraries that bpy loads ($(echo $libs));"
else
	say "no ldconfig: cannot check for bpy's X11/GL libraries (${LIBS})"
fi

if [ -n "$pkgs" ]; then
	# shellcheck disable=SC2086
	if [ -n "$APT" ]; then
		say "missing:${missing%;}"
		apt_install $pkgs
	else
		m=${missing# }
		stop "${m%;}" "$(echo $pkgs)"
	fi
fi
say "Python $V ($PY): bpy $(case $V in 3.11) echo 4.2 ;; *) echo 5.2 ;; esac); venv, headers, compiler and bpy's libraries present"
echo "$PY"

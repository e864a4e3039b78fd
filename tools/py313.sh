#!/bin/sh
# Python 3.13 on a Debian 12 host, through a Debian trixie chroot.
#
#   sh tools/py313.sh setup [--bpy]   build/refresh the chroot (idempotent; a finished one takes seconds)
#   sh tools/py313.sh run CMD ARGS... run CMD in the chroot with $PWD bind-mounted at /src (the cwd);
#                                     exits with CMD's status; nothing stays mounted on the host.
# e.g. sh tools/py313.sh run /opt/venv/bin/python -m pytest tests
#
# The chroot has python3.13 and a venv at /opt/venv with numpy and pytest. --bpy adds the
# X11/GL libraries bpy links against and bpy==$BPY_VERSION from PyPI (~400 MB download).
# CMD gets a clean environment (env -i); pass variables with `run env NAME=VALUE CMD...`.
#
# Env: UNBOUND_PY313_ROOT (default /opt/unbound-py313), BPY_VERSION (default 5.2.3),
#      DEBIAN_MIRROR (default http://deb.debian.org/debian).
# setup needs root (debootstrap, apt); run works as root, or otherwise through a user namespace.
set -eu

ROOT=${UNBOUND_PY313_ROOT:-/opt/unbound-py313}
BPY_VERSION=${BPY_VERSION:-5.2.3}
MIRROR=${DEBIAN_MIRROR:-http://deb.debian.org/debian}
CA=/etc/ssl/certs/ca-certificates.crt
# libegl1: the 5.x compositor opens libEGL even in background mode.
BPY_LIBS="libx11-6 libxext6 libxi6 libxrender1 libxfixes3 libxkbcommon0 libsm6 libice6 libxt6t64 libgl1 libegl1"

say() { echo "py313: $*" >&2; }
die() { say "error: $*"; exit 1; }

# inroot [-s] CMD...: run CMD inside the chroot, in private pid+mount namespaces so that /proc,
# /dev/pts, /dev/shm and the /src bind mount vanish with it. -s: bind-mount $PWD at /src, cwd /src.
inroot() {
	src=
	if [ "${1:-}" = -s ]; then src=$(pwd -P); shift; fi
	userns=
	[ "$(id -u)" = 0 ] || userns=--map-root-user
	unshare $userns --fork --pid --mount --propagation private --kill-child sh -euc '
		R=$1 SRC=$2 D=/
		shift 2
		mount -t proc proc "$R/proc"
		[ -c "$R/dev/null" ] || mount --rbind /dev "$R/dev"
		mount -t devpts -o newinstance,ptmxmode=0666 devpts "$R/dev/pts" 2>/dev/null || :
		[ ! -d "$R/dev/shm" ] || mount -t tmpfs -o mode=1777 shm "$R/dev/shm" 2>/dev/null || :
		if [ -n "$SRC" ]; then
			mkdir -p "$R/src"
			mount --bind "$SRC" "$R/src"
			D=/src
		fi
		exec chroot "$R" /usr/bin/env -i -C "$D" "$@"
	' sh "$ROOT" "$src" \
		PATH=/opt/venv/bin:/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
		HOME=/root LANG=C.UTF-8 TERM="${TERM:-dumb}" DEBIAN_FRONTEND=noninteractive \
		PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_CACHE_DIR=1 PIP_DEFAULT_TIMEOUT=180 \
		PIP_CERT=$CA SSL_CERT_FILE=$CA REQUESTS_CA_BUNDLE=$CA \
		"$@"
}

# Before anything in the chroot goes to the network: host DNS settings and the host's extra CA
# certificates (without them pip fails with CERTIFICATE_VERIFY_FAILED behind a TLS proxy).
net_ready=
net() {
	[ -z "$net_ready" ] || return 0
	cp -L /etc/resolv.conf "$ROOT/etc/resolv.conf"
	mkdir -p "$ROOT/usr/local/share/ca-certificates"
	for c in /usr/local/share/ca-certificates/*.crt; do
		[ ! -f "$c" ] || cp "$c" "$ROOT/usr/local/share/ca-certificates/"
	done
	[ ! -x "$ROOT/usr/sbin/update-ca-certificates" ] || inroot update-ca-certificates >/dev/null
	net_ready=1
}

apt_in() {
	net
	inroot apt-get update -qq || die "apt-get update failed in the chroot"
	inroot apt-get install -y -qq --no-install-recommends "$@" >/dev/null || die "apt-get install $* failed"
	inroot apt-get clean
}

setup() {
	bpy=
	for a in "$@"; do
		case $a in
		--bpy) bpy=1 ;;
		*) die "setup: unknown option $a" ;;
		esac
	done
	[ "$(id -u)" = 0 ] || die "setup needs root (debootstrap, chroot, apt)"
	mkdir -p "$(dirname "$ROOT")"
	if command -v flock >/dev/null; then
		exec 9>"$ROOT.lock"
		flock 9
	fi

	if [ ! -e "$ROOT/.unbound-base" ]; then
		if [ ! -e "$ROOT/etc/os-release" ]; then
			if ! command -v debootstrap >/dev/null; then
				say "installing debootstrap on the host"
				apt-get update -qq && apt-get install -y -qq debootstrap >/dev/null ||
					die "could not install debootstrap"
			fi
			rmdir "$ROOT" 2>/dev/null || [ ! -e "$ROOT" ] || die "$ROOT exists but is no chroot; remove it"
			say "debootstrap trixie (minbase) into $ROOT (~40 s)"
			# Build beside $ROOT and rename, so that a failed run leaves no half-made chroot.
			rm -rf "$ROOT.new"
			debootstrap --variant=minbase trixie "$ROOT.new" "$MIRROR" >"$ROOT.debootstrap.log" 2>&1 || {
				tail -n 15 "$ROOT.debootstrap.log" >&2
				die "debootstrap failed (log: $ROOT.debootstrap.log)"
			}
			rm -f "$ROOT.debootstrap.log"
			mv "$ROOT.new" "$ROOT"
		fi
		say "apt-get install python3.13 python3.13-venv ca-certificates"
		apt_in ca-certificates python3.13 python3.13-venv
		ln -sf ../proc/self/mounts "$ROOT/etc/mtab"
		touch "$ROOT/.unbound-base"
	fi

	# (not -x bin/python: it links to /usr/bin/python3.13, which the host lacks)
	if [ ! -e "$ROOT/opt/venv/pyvenv.cfg" ]; then
		say "creating venv /opt/venv"
		inroot python3.13 -m venv /opt/venv
	fi
	if ! inroot python -c 'import numpy, pytest' 2>/dev/null; then
		say "pip install numpy pytest"
		net
		inroot pip install -q numpy pytest || die "pip install numpy pytest failed"
	fi

	if [ -n "$bpy" ]; then
		if [ ! -e "$ROOT/.unbound-bpy-libs-2" ]; then
			say "apt-get install X11/GL libraries for bpy"
			# shellcheck disable=SC2086
			apt_in $BPY_LIBS
			touch "$ROOT/.unbound-bpy-libs-2"
		fi
		if ! inroot python -c "import importlib.metadata as m, sys; sys.exit(m.version('bpy') != '$BPY_VERSION')" 2>/dev/null; then
			say "pip install bpy==$BPY_VERSION (~400 MB)"
			net
			inroot pip install -q "bpy==$BPY_VERSION" || die "pip install bpy==$BPY_VERSION failed"
		fi
		if ! inroot python -c 'import OpenImageIO' 2>/dev/null; then
			say "pip install OpenImageIO"
			net
			inroot pip install -q OpenImageIO || die "pip install OpenImageIO failed"
		fi
	fi

	inroot python -c 'import sys, numpy; print("py313: ready: Python", sys.version.split()[0], "numpy", numpy.__version__, file=sys.stderr)'
	[ -z "$bpy" ] || inroot python -c 'import bpy, sys; print("py313: bpy", bpy.app.version_string, file=sys.stderr)'
}

case ${1:-} in
setup)
	shift
	setup "$@"
	;;
run)
	shift
	[ $# -gt 0 ] || die "usage: $0 run CMD [ARGS...]"
	[ -e "$ROOT/.unbound-base" ] || die "no chroot at $ROOT; run: sh $0 setup"
	inroot -s "$@"
	;;
*)
	echo "usage: sh $0 setup [--bpy] | run CMD [ARGS...]" >&2
	exit 2
	;;
esac

#!/bin/sh
# The real Blender binary (Debian trixie's blender 4.3, Python 3.13) in the trixie chroot of
# tools/py313.sh: background renders, `blender --command extension ...`, and the GUI under a
# private Xvfb (Mesa llvmpipe, OpenGL 4.5) with screenshots grabbed by ffmpeg's x11grab.
#
#   sh tools/blender_gui.sh setup          py313.sh setup, then apt-get install blender, python3-numpy,
#                                          xvfb, xauth, ffmpeg (no recommends) into the chroot; idempotent
#   sh tools/blender_gui.sh run CMD...     run CMD in the chroot, $PWD bind-mounted at /src (the cwd)
#   sh tools/blender_gui.sh gui CMD...     same, with a private tmpfs /tmp and a private Xvfb; DISPLAY is set,
#                                          CMD runs under `timeout $BL_TIMEOUT`; Xvfb is stopped afterwards
# e.g.
#   sh tools/blender_gui.sh run blender --command extension validate dist/unbound-0.1.0.zip
#   sh tools/blender_gui.sh gui blender -p 0 0 1600 900 --python script.py -- /src/build/screenshots
#
# Paths inside are chroot paths (/src/...). CMD gets a clean environment (env -i) plus
# XDG_CACHE_HOME=/root/.cache (Blender's and Mesa's shader caches outlive the private /tmp);
# pass more with `run env NAME=VALUE CMD...`.
# Why not bpy.ops.screen.screenshot: it saves an all-black image on the OpenGL backend under Xvfb
# (Mesa's software GLX leaves the front buffer empty), so grab the X screen instead:
#   ffmpeg -f x11grab -draw_mouse 0 -i "$DISPLAY" -frames:v 1 shot.png
#
# Env: UNBOUND_PY313_ROOT (the chroot; default /opt/unbound-py313), XVFB_SCREEN (default 1600x900x24),
#      BL_TIMEOUT (seconds for a `gui` command; default 600).
# setup needs root; run and gui work as root (CI) or through a user namespace.
set -eu

HERE=$(cd "$(dirname "$0")" && pwd -P)
PY313="$HERE/py313.sh"
ROOT=${UNBOUND_PY313_ROOT:-/opt/unbound-py313}
XVFB_SCREEN=${XVFB_SCREEN:-1600x900x24}
BL_TIMEOUT=${BL_TIMEOUT:-600}
# libgl1-mesa-dri: llvmpipe (xvfb pulls it in today; named so that GL never silently goes missing).
PKGS="blender python3-numpy xvfb xauth ffmpeg libgl1-mesa-dri"

say() { echo "blender_gui: $*" >&2; }
die() { say "error: $*"; exit 1; }

inrun() {
	UNBOUND_PY313_ROOT=$ROOT sh "$PY313" run env XDG_CACHE_HOME=/root/.cache \
		XVFB_SCREEN="$XVFB_SCREEN" BL_TIMEOUT="$BL_TIMEOUT" "$@"
}

# Runs as the command inside the chroot (PID 1 of its pid namespace, so no xvfb-run: it waits for
# Xvfb's SIGUSR1, which never comes there). Xvfb picks a free display and writes it to fd 3
# (-displayfd); its lock files live on the private /tmp, so nothing is left behind.
XWRAP='
	mount -t tmpfs -o mode=1777 tmpfs /tmp || { echo "blender_gui: cannot mount a private /tmp" >&2; exit 97; }
	Xvfb -displayfd 3 -screen 0 "$XVFB_SCREEN" -nolisten tcp 3>/tmp/.xvfb-display >/tmp/xvfb.log 2>&1 &
	XP=$!
	i=0
	while [ ! -s /tmp/.xvfb-display ]; do
		i=$((i + 1))
		if [ $i -gt 400 ] || ! kill -0 $XP 2>/dev/null; then
			echo "blender_gui: Xvfb did not start:" >&2; cat /tmp/xvfb.log >&2; exit 98
		fi
		sleep 0.05
	done
	DISPLAY=:$(head -n 1 /tmp/.xvfb-display)
	export DISPLAY
	rc=0
	timeout -k 10 "$BL_TIMEOUT" "$@" || rc=$?
	kill $XP 2>/dev/null || :
	wait $XP 2>/dev/null || :
	exit $rc'

setup() {
	[ "$(id -u)" = 0 ] || die "setup needs root"
	UNBOUND_PY313_ROOT=$ROOT sh "$PY313" setup
	if command -v flock >/dev/null; then
		exec 8>"$ROOT.blender.lock"
		flock 8
	fi
	# shellcheck disable=SC2086
	missing=$(inrun dpkg-query -W -f='${db:Status-Abbrev} ${Package}\n' $PKGS 2>&1 | grep -v '^ii ' || :)
	if [ -n "$missing" ]; then
		say "apt-get install --no-install-recommends $PKGS (~300 packages, ~1 GB; 1-2 min)"
		cp -L /etc/resolv.conf "$ROOT/etc/resolv.conf"
		inrun apt-get update -qq || die "apt-get update failed in the chroot"
		# --no-install-recommends: with recommends blender pulls ~390 packages (systemd, dbus, gtk3 ...).
		# shellcheck disable=SC2086
		inrun apt-get install -y -qq --no-install-recommends $PKGS >/dev/null || die "apt-get install failed"
		inrun apt-get clean
	fi
	inrun blender --version | head -n 1 | sed 's/^/blender_gui: ready: /' >&2
}

case ${1:-} in
setup)
	shift
	setup
	;;
run)
	shift
	[ $# -gt 0 ] || die "usage: $0 run CMD [ARGS...]"
	inrun "$@"
	;;
gui)
	shift
	[ $# -gt 0 ] || die "usage: $0 gui CMD [ARGS...]"
	inrun sh -c "$XWRAP" sh "$@"
	;;
*)
	echo "usage: sh $0 setup | run CMD [ARGS...] | gui CMD [ARGS...]" >&2
	exit 2
	;;
esac

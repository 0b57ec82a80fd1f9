#!/bin/sh
# fake_ssh.sh [ssh options] HOST [--] COMMAND... - what GNU parallel's --ssh
# calls to reach HOST, here run on this machine (tests/sweep_spec.lua: two
# "hosts" that are both this one).  Each call appends HOST to $FAKE_SSH_LOG.
while [ $# -gt 0 ]; do
  case "$1" in
    -*) shift ;;
    *) break ;;
  esac
done
host=$1
shift
[ "$1" = "--" ] && shift
[ -n "$FAKE_SSH_LOG" ] && echo "$host" >>"$FAKE_SSH_LOG"
# A login over ssh sets SHELL and HOME; GNU parallel's remote wrapper runs the
# job with $SHELL, so without it (a CI job started with a bare environment)
# every job would silently run nothing.
export SHELL="${SHELL:-/bin/sh}" HOME="${HOME:-/tmp}"
exec sh -c "$*"

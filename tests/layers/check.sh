#!/bin/sh
# The layer rules (tools/check_layers.py) hold on this build, and each committed bad fixture
# is flagged with its rule's message, so that the check is seen to fail.
#   check.sh SOURCE_DIR BUILD_DIR
set -u
src=$1 build=$2
cd "$src" || exit 1
fail() { echo "layers: $*" >&2; exit 1; }
python3 tools/check_layers.py "$build" || fail "the tree breaks a layer rule (above)"
expect() { # FIXTURE-ARGS... -- MESSAGE
  msg=$1; shift
  out=$(python3 tools/check_layers.py "$@" 2>&1); rc=$?
  [ $rc -eq 1 ] || fail "$* exited $rc, not 1: $out"
  printf '%s\n' "$out" | grep -q -- "$msg" || fail "$*: no '$msg' in: $out"
}
expect "encoder/nerf includes encoder/compress" --depfiles tests/layers/nerf_includes_compress.d
expect "the encoder includes decoder internals" --depfiles tests/layers/encoder_includes_decoder.d
expect "the decoder includes encoder/base/cn_buf.h" --depfiles tests/layers/decoder_includes_encoder.d
expect "common/ includes decoder/cn_internal.h" --depfiles tests/layers/common_includes_decoder.d
expect "cmd_eval.c: uses cli_load_dataset of platform/host/cmd_train.c" --nm tests/layers/commands.nm
expect "cmd_quantize.c: calls cn_write_stream outside the encode pipeline" --nm tests/layers/pipeline.nm
expect "cmd_render.c: calls rename outside the write module" --nm tests/layers/writes.nm
echo "layers: the rules hold, and the seven bad fixtures are flagged"

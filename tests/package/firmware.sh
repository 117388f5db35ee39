#!/usr/bin/env bash
# ctest package_firmware: the decoder cross-built for the Cortex-M4, installed as a package,
# and used by an outside firmware project (examples/firmware, through find_package) as a
# user would. The firmware renders a view of vector 001's stream from a camera it makes
# itself (cnerf_camera_look_at), row by row, into a file over semihosting under QEMU; the
# host example (examples/host) renders the same camera, which the firmware prints, and the
# two images must be the same bytes.
#   firmware.sh BUILD_DIR
set -euo pipefail
build=$1
root=$(cd "$(dirname "$0")/../.." && pwd)
for tool in arm-none-eabi-gcc qemu-system-arm; do
  command -v $tool > /dev/null || { echo "package_firmware: $tool is missing"; exit 1; }
done
rm -rf "$build"
cmake -S "$root" -B "$build/m4" -DCMAKE_TOOLCHAIN_FILE="$root/cmake/toolchains/arm-none-eabi.cmake" \
  -DCNERF_BUILD_ENCODER=OFF -DCNERF_BUILD_TESTS=OFF -DCMAKE_BUILD_TYPE=MinSizeRel > /dev/null
cmake --build "$build/m4" -j2 --target cnerf_dec cnerf_dec_tools > /dev/null
cmake --install "$build/m4" --prefix "$build/prefix-m4" > /dev/null
echo "installed for the Cortex-M4: $(cd "$build/prefix-m4" && find . -name '*.a' | sort | tr '\n' ' ')"
stream=$root/vectors/valid/001-lego-encode-tiny.cnrf
cmake -S "$root/examples/firmware" -B "$build/example" -DCMAKE_PREFIX_PATH="$build/prefix-m4" \
  -DCMAKE_TOOLCHAIN_FILE="$root/examples/firmware/cortex-m4.cmake" -DSCENE_STREAM="$stream" \
  -DSCENE_SIZE="48 36" > /dev/null
cmake --build "$build/example" > /dev/null
echo "examples/firmware builds with find_package(cnerf)"
if ! (cd "$build/example" && timeout 600 qemu-system-arm -M mps2-an386 -nographic \
       -semihosting-config enable=on,target=native -kernel render_scene.elf < /dev/null) \
     > "$build/fw.out" 2>&1; then
  cat "$build/fw.out"
  echo "FAIL: the firmware example failed under QEMU"
  exit 1
fi
cat "$build/fw.out"
sed -n 's/^camera //p' "$build/fw.out" > "$build/camera.txt"
[ "$(wc -w < "$build/camera.txt")" = 18 ] || { echo "FAIL: the firmware printed no camera"; exit 1; }

cmake -S "$root" -B "$build/host" -DCNERF_BUILD_ENCODER=OFF -DCNERF_BUILD_TESTS=OFF \
  -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build "$build/host" -j2 > /dev/null
cmake --install "$build/host" --prefix "$build/prefix-host" > /dev/null
cmake -S "$root/examples/host" -B "$build/host-example" -DCMAKE_PREFIX_PATH="$build/prefix-host" > /dev/null
cmake --build "$build/host-example" > /dev/null
"$build/host-example/render_rows" "$stream" "$build/camera.txt" "$build/host.ppm"
fw=$(md5sum < "$build/example/view.ppm" | cut -c1-32)
host=$(md5sum < "$build/host.ppm" | cut -c1-32)
echo "firmware view.ppm $fw, host render of its camera $host"
[ "$fw" = "$host" ] || { echo "FAIL: the firmware's view differs from the host's"; exit 1; }
# and the view is a picture, not a blank: some pixel differs from the first
[ "$(tail -c +16 "$build/host.ppm" | od -An -v -tu1 | tr -s ' ' '\n' | sed '/^$/d' | sort -u | wc -l)" -gt 8 ] ||
  { echo "FAIL: the view is blank"; exit 1; }
echo "package_firmware: OK"

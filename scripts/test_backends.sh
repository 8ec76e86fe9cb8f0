#!/bin/sh
# Run a test command on every Blender x GPU backend users have (Makefile: test-zip, test-gpu53).
#
#   scripts/test_backends.sh CASES -- COMMAND...
#
# CASES: space-separated version:BACKEND pairs (5.3.0:VULKAN 5.3.0:OPENGL 5.2.4:OPENGL ...). COMMAND runs once per
# case with BPY_VERSION set to the case's version and TRANSLUCENT_EXPECT_BACKEND to its backend (the tests check
# Blender really ran there). Blender 5.3 picks Vulkan wherever a Vulkan driver is installed; its OpenGL case hides
# the driver (VK_ICD_FILENAMES pointed at nothing makes Blender fall back). Without a Vulkan driver the Vulkan
# cases are skipped and said so in one line; under CI (CI=true) that skip fails the run.
cases="$1"
shift
[ "$1" = "--" ] && shift
has_vulkan_driver() {
    for dir in /usr/share/vulkan/icd.d /etc/vulkan/icd.d /usr/local/share/vulkan/icd.d; do
        ls "$dir"/*.json >/dev/null 2>&1 && return 0
    done
    return 1
}
skipped=""
for case in $cases; do
    version="${case%%:*}"
    backend="${case#*:}"
    if [ "$backend" = VULKAN ] && ! has_vulkan_driver; then
        skipped="$skipped bpy $version on Vulkan;"
        continue
    fi
    echo "== bpy $version on $backend: $*"
    if [ "$backend" = OPENGL ]; then
        BPY_VERSION="$version" TRANSLUCENT_EXPECT_BACKEND=OPENGL VK_ICD_FILENAMES=/nonexistent.json "$@" || exit 1
    else
        BPY_VERSION="$version" TRANSLUCENT_EXPECT_BACKEND="$backend" "$@" || exit 1
    fi
done
if [ -n "$skipped" ]; then
    echo "SKIPPED:$skipped no Vulkan driver here (Debian: apt-get install mesa-vulkan-drivers)"
    if [ "${CI:-}" = true ]; then
        echo "CI does not pass with a backend skipped"
        exit 1
    fi
fi
exit 0

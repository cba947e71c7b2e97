#!/usr/bin/env bash
# Makes this machine able to build and run pathmix: installs Mesa's software
# Vulkan driver (lavapipe) and the Vulkan loader when no Vulkan driver is
# installed. Debian/Ubuntu; run as root or with sudo available.
set -euo pipefail

have_vulkan_driver() {
    # An installable client driver manifest is what the Vulkan loader looks for.
    compgen -G "/usr/share/vulkan/icd.d/*.json" >/dev/null \
        || compgen -G "/etc/vulkan/icd.d/*.json" >/dev/null
}

have_vulkan_loader() {
    ldconfig -p 2>/dev/null | grep -q 'libvulkan\.so\.1'
}

if have_vulkan_driver && have_vulkan_loader; then
    echo "setup: a Vulkan driver is installed; nothing to do"
else
    if [ "$(id -u)" -eq 0 ]; then
        sudo=()
    elif command -v sudo >/dev/null; then
        sudo=(sudo)
    else
        echo "setup: no Vulkan driver, and neither root nor sudo to install one:" >&2
        echo "       apt-get install mesa-vulkan-drivers libvulkan1" >&2
        exit 1
    fi
    echo "setup: installing Mesa's Vulkan drivers (lavapipe) and the Vulkan loader"
    "${sudo[@]}" apt-get update -qq
    DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends \
        mesa-vulkan-drivers libvulkan1 >/dev/null
fi

if ! command -v cargo >/dev/null; then
    echo "setup: cargo not found: install Rust (https://rustup.rs) and run again" >&2
    exit 1
fi

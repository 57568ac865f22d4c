# Shared helpers for the tests/vm scripts (sourced, not executed).
#
# Defines:
#   vm_dir, repo_root    where the harness and the repository live
#   vm_cache_dir         cache for the guest kernel + initramfs ($RMD_VM_CACHE)
#   vm_modules           kernel modules the guest loads, in the recipe's order
#   vm_log MSG...        one line on stderr, prefixed with the calling script's name
#   host_vcan_ok         true if this kernel can create vcan links itself (root only)
#   host_netns_ok        true if we may run the command in a fresh network namespace
#   vm_kernel_version    newest installed Debian kernel with /boot/vmlinuz + vcan.ko
#   vm_missing_tools     names of the programs the VM path needs but cannot find

# shellcheck shell=sh disable=SC2034 # the variables are for the sourcing scripts

vm_dir=$(cd "$(dirname "$0")" && pwd -P)
repo_root=$(cd "$vm_dir/../.." && pwd -P)
vm_cache_dir=${RMD_VM_CACHE:-$repo_root/build/vm}

# virtio transport + 9p to reach the host's root, overlay for a systemd boot
# (vm-run --systemd), then the CAN stack.  Their dependencies (netfs, 9pnet,
# can-dev, ...) are resolved with modprobe -S.
vm_modules="virtio_pci virtio_mmio 9pnet_virtio 9p overlay can can_raw can_bcm can_gw vcan"

vm_log()
{
	echo "$(basename "$0"): $*" >&2
}

# The probe runs in a throwaway network namespace when possible so it never
# touches the host's own interfaces.
host_netns_ok()
{
	[ "$(id -u)" -eq 0 ] && command -v unshare >/dev/null 2>&1 &&
		unshare -n true 2>/dev/null
}

host_vcan_ok()
{
	[ "$(id -u)" -eq 0 ] || return 1
	command -v ip >/dev/null 2>&1 || return 1
	modprobe vcan 2>/dev/null || true # may be built in, or already loaded
	if host_netns_ok; then
		unshare -n sh -c 'ip link add dev vcanprobe type vcan' 2>/dev/null
	else
		ip link add dev "rmdprobe$$" type vcan 2>/dev/null &&
			ip link del dev "rmdprobe$$" 2>/dev/null
	fi
}

# Debian's linux-image-amd64 installs /boot/vmlinuz-KVER and /lib/modules/KVER.
# RMD_VM_KERNEL=KVER picks one explicitly.
vm_kernel_version()
{
	if [ -n "${RMD_VM_KERNEL:-}" ]; then
		echo "$RMD_VM_KERNEL"
		return 0
	fi
	for k in $(ls /lib/modules 2>/dev/null | sort -rV); do
		if [ -r "/boot/vmlinuz-$k" ] &&
			[ -n "$(find "/lib/modules/$k" -name 'vcan.ko*' 2>/dev/null)" ]; then
			echo "$k"
			return 0
		fi
	done
	return 1
}

vm_missing_tools()
{
	missing=""
	for t in qemu-system-x86_64 modprobe cpio xz timeout; do
		command -v "$t" >/dev/null 2>&1 || missing="$missing $t"
	done
	[ -x /bin/busybox ] || missing="$missing busybox(-static)"
	echo "${missing# }"
}

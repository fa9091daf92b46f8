# SPDX-License-Identifier: MIT
# Sourced by the udpm tests. private_netns SCRIPT ARGS... re-executes SCRIPT inside a new
# network namespace (unshare -n) and, once inside, brings up a loopback that carries multicast
# and sets $url: udpm traffic can never reach a real interface. Where a namespace may not be
# made, the test is skipped (exit 77); a failed exec never falls back to the real network.
private_netns() {
    if [ -z "${LIDARFLOW_IN_PRIVATE_NETNS:-}" ]; then
        unshare -n true 2>/dev/null || { echo "skipped: not permitted to create a network namespace (unshare -n)"; exit 77; }
        LIDARFLOW_IN_PRIVATE_NETNS=1 exec unshare -n bash "$@"
        exit 1
    fi
    # Inside the namespace: only a loopback may exist, or we stop.
    if [ "$(ip -o link show | grep -vc ': lo:')" != 0 ]; then echo "not a private namespace"; exit 1; fi
    ip link set lo up && ip link set lo multicast on && ip route add 224.0.0.0/4 dev lo || exit 1
    # Room for multi-MB messages (per namespace on recent kernels; not fatal if refused).
    sysctl -qw net.core.rmem_max=16777216 2>/dev/null || true
    url='udpm://239.255.76.67:7667?ttl=0&recv_buf_size=16777216'
}

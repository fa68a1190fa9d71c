#!/usr/bin/env bash
# Hosts on one machine: Linux network namespaces on a bridge, each one a
# "machine" with its own network stack, for running a swarm across hosts.
#
#   sudo scripts/netns_hosts.sh up N          make hosts 0..N-1 (10.77.0.10, .11, ...)
#   sudo scripts/netns_hosts.sh exec K CMD... run CMD on host K, as its machine would
#   sudo scripts/netns_hosts.sh down          remove every host and the bridge
#
# SWAZURE_NETNS_MULTICAST=off makes hosts without multicast, as networks that drop it
# (many Wi-Fi ones): simple discovery cannot work there, the Discovery Server can.
#
# SWAZURE_NETNS_PREFIX (default swz) names the namespaces (PREFIXh0, ...), the
# bridge (PREFIXbr) and the host ends of the veth pairs, so that two test runs
# do not meet. `up` removes what an earlier run of the same prefix left, and
# a failure half way removes what it made. Needs root (CAP_NET_ADMIN).
set -euo pipefail

prefix=${SWAZURE_NETNS_PREFIX:-swz}
bridge=${prefix}br
subnet=${SWAZURE_NETNS_SUBNET:-10.77.0}
multicast=${SWAZURE_NETNS_MULTICAST:-on}

hosts() { ip netns list | awk '{print $1}' | grep -E "^${prefix}h[0-9]+$" || true; }

veths() { ip -o link show | awk -F': ' '{print $2}' | cut -d@ -f1 | grep -E "^${prefix}v[0-9]+$" || true; }

down() {
    # The host ends first: deleting a veth end deletes its pair at once, whereas a
    # deleted namespace's devices go in the kernel's deferred cleanup, and an `up`
    # right after would find the old ${prefix}vK still there ("File exists").
    for veth in $(veths); do ip link delete "$veth"; done
    for ns in $(hosts); do ip netns delete "$ns"; done
    if ip link show "$bridge" >/dev/null 2>&1; then ip link delete "$bridge"; fi
}

up() {
    local count=$1
    [[ $count =~ ^[0-9]+$ && $count -ge 1 && $count -le 200 ]] || {
        echo "netns_hosts: up needs a host count 1..200, got '$count'" >&2; exit 2; }
    down
    trap 'down' ERR
    ip link add "$bridge" type bridge
    # Without an IGMP querier a snooping bridge can starve DDS discovery's multicast.
    ip link set "$bridge" type bridge mcast_snooping 0
    ip link set "$bridge" up
    for ((i = 0; i < count; i++)); do
        local ns=${prefix}h$i veth=${prefix}v$i
        ip netns add "$ns"
        ip link add "$veth" type veth peer name eth0 netns "$ns"
        ip link set "$veth" master "$bridge" up
        ip -n "$ns" addr add "$subnet.$((10 + i))/24" dev eth0
        ip -n "$ns" link set lo up
        ip -n "$ns" link set eth0 up
        # DDS discovery multicasts to 239.255.0.1: route multicast out of eth0.
        ip -n "$ns" route add 224.0.0.0/4 dev eth0
        if [[ $multicast == off ]]; then
            # The bridge hands no host's multicast to another (a host still hears its own).
            bridge link set dev "$veth" mcast_flood off
        fi
    done
    trap - ERR
    echo "hosts up: $(hosts | sort -V | tr '\n' ' ')on bridge $bridge ($subnet.0/24)"
}

run_on() {
    local index=$1; shift
    local ns=${prefix}h$index
    ip netns list | awk '{print $1}' | grep -qx "$ns" || {
        echo "netns_hosts: no host $index (run: $0 up N)" >&2; exit 2; }
    # As on separate machines: discovery over the subnet, UDP only (no shared memory).
    exec ip netns exec "$ns" env ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET \
        FASTDDS_BUILTIN_TRANSPORTS=UDPv4 "$@"
}

case ${1:-} in
    up) up "${2:-}" ;;
    down) down ;;
    exec) [[ $# -ge 3 ]] || { echo "usage: $0 exec K CMD..." >&2; exit 2; }; shift; run_on "$@" ;;
    *) echo "usage: $0 up N | exec K CMD... | down" >&2; exit 2 ;;
esac

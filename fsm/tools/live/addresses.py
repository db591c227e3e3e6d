"""Which names a live page may be reached by, and which addresses to print for a server that listens on all.

A browser sends the name it used in ``Host`` (and, for a WebSocket or a form, the page's site in ``Origin``). The
server answers only names that are its own: the address it listens on, this machine's names and, when it listens
on every interface (``0.0.0.0``, ``::``), each interface's address. A page of another site that made its own name
point at 127.0.0.1 (DNS rebinding) sends its own name, and is refused, token or not.
"""

from __future__ import annotations

import ipaddress
import socket
from pathlib import Path
from urllib.parse import urlsplit

#: Hosts that mean "every interface of this machine".
ANY = ("0.0.0.0", "::", "")
#: Names of this machine only.
LOOPBACK_NAMES = ("127.0.0.1", "localhost", "::1")


def interface_addresses() -> list[str]:
    """This machine's own addresses, IPv4 first, loopback last (Linux: each interface's; else what the host name
    resolves to)."""
    found: list[str] = []
    try:  # IPv4: each interface's address (Linux's SIOCGIFADDR)
        import fcntl
        import struct

        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            for _index, name in socket.if_nameindex():
                try:
                    packed = fcntl.ioctl(s.fileno(), 0x8915, struct.pack("256s", name.encode()[:15]))
                except OSError:
                    continue  # no IPv4 address on it
                found.append(socket.inet_ntoa(packed[20:24]))
    except (ImportError, OSError, AttributeError):
        pass
    try:  # IPv6: /proc/net/if_inet6 (global and link-local addresses are of no use in a URL without a zone)
        for line in Path("/proc/net/if_inet6").read_text().splitlines():
            raw = line.split()[0]
            address = ipaddress.IPv6Address(int(raw, 16))
            if not address.is_link_local:
                found.append(str(address))
    except (OSError, ValueError, IndexError):
        pass
    try:
        for info in socket.getaddrinfo(socket.gethostname(), None):
            found.append(str(info[4][0]))
    except OSError:
        pass
    unique = list(dict.fromkeys(a.split("%")[0] for a in found))
    return sorted(unique, key=lambda a: (ipaddress.ip_address(a).is_loopback, ":" in a, a))


def machine_names() -> list[str]:
    """This machine's host names (as another machine on the network may call it)."""
    names = [socket.gethostname()]
    try:
        names.append(socket.getfqdn())
    except OSError:
        pass
    return [n.lower() for n in dict.fromkeys(names) if n]


def netloc(host: str, port: int) -> str:
    """``host:port`` as a URL has it (an IPv6 address in brackets)."""
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


def allowed_hosts(host: str, port: int) -> set[str]:
    """The ``Host`` values (``name:port``, lower case) a server listening on ``host``:``port`` answers."""
    names: set[str] = set(LOOPBACK_NAMES) if is_loopback(host) or host in ANY else set()
    if host in ANY:
        names.update(interface_addresses())
        names.update(machine_names())
    elif not is_loopback(host):
        names.add(host.lower())
        names.update(machine_names())
    out = {netloc(n, port) for n in names}
    if port == 80:  # a browser leaves the default port out
        out.update(f"[{n}]" if ":" in n else n for n in names)
    return out


def usable_urls(host: str, port: int, suffix: str) -> list[str]:
    """The URLs another machine (or this one) can open for a server on ``host``:``port``: for every interface when
    ``host`` is all of them (``0.0.0.0`` cannot be opened), else the one."""
    hosts = [host]
    if host in ANY:  # 0.0.0.0 is every IPv4 interface; :: (and "") every one, IPv6 too
        hosts = [a for a in interface_addresses() if host != "0.0.0.0" or ":" not in a]
    return [f"http://{netloc(h, port)}/{suffix}" for h in hosts]


def is_loopback(host: str) -> bool:
    """Whether ``host`` is this machine only."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def origin_allowed(origin: str | None, hosts: set[str]) -> bool:
    """Whether a request's ``Origin`` (``None``: none sent, as for a typed URL) is one of this server's pages."""
    if origin is None:
        return True
    parts = urlsplit(origin)
    return parts.scheme in ("http", "https") and parts.netloc.lower() in hosts


__all__ = ["allowed_hosts", "interface_addresses", "is_loopback", "netloc", "origin_allowed", "usable_urls"]

"""canopen-drive-linux under hostile clients and a careless supervisor (issue 19): output that
cannot stop the drive, a flooding client, connection limits, damaged storage.

Every check is what an outside observer sees: answered SDOs and their latency, frames on the
bus, the process's exit status, its resident memory and thread count (/proc), what it prints.
Bounds on time and memory are generous: the machines are shared and loaded.
"""

import os
import pathlib
import resource
import select
import shutil
import signal
import socket
import struct
import subprocess
import threading
import time

import canopen
import pytest

from conftest import NODE_ID, READY_TIMEOUT, binary_path, free_port

SDO_UPLOAD_1000 = b"t60584000100000000000\r"  # initiate upload of 1000h sub 0 to node 5
SDO_RESPONSE = b"t5858"  # any response of node 5's SDO server (DLC 8)


class Program:
    """The drive with its stdout and stderr as pipes the test may read, leave or close."""

    def __init__(self, *args, node_id=NODE_ID, preexec_fn=None):
        self.port = free_port()
        command = [str(binary_path()), "--node-id", str(node_id), "--slcan-listen", f"127.0.0.1:{self.port}", *args]
        self.proc = subprocess.Popen(
            command, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, preexec_fn=preexec_fn
        )
        ready, _, _ = select.select([self.proc.stdout], [], [], READY_TIMEOUT)
        line = self.proc.stdout.readline() if ready else b""
        if line != b"ready\n":
            self.proc.kill()
            pytest.fail(f"no ready line: {line!r} {self.proc.stderr.read()!r}")
        self.stderr_text = b""

    @property
    def channel(self):
        return f"socket://127.0.0.1:{self.port}"

    def status(self, field):
        """A field of /proc/PID/status as a number (VmRSS in kB, Threads)."""
        for line in pathlib.Path(f"/proc/{self.proc.pid}/status").read_text().splitlines():
            if line.startswith(field + ":"):
                return int(line.split()[1])
        raise KeyError(field)

    def read_stderr(self, timeout=1.0):
        """What stderr has said so far (the pipe is read only here, and by `stop`)."""
        deadline = time.monotonic() + timeout
        while not self.proc.stderr.closed and time.monotonic() < deadline:
            ready, _, _ = select.select([self.proc.stderr], [], [], 0.05)
            if ready:
                chunk = os.read(self.proc.stderr.fileno(), 65536)
                if not chunk:
                    break
                self.stderr_text += chunk
        return self.stderr_text.decode(errors="replace")

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if not self.proc.stderr.closed:
            self.stderr_text += self.proc.stderr.read()  # the process is gone: up to EOF
        for pipe in (self.proc.stdout, self.proc.stderr):
            if pipe and not pipe.closed:
                pipe.close()
        return self.proc.returncode


def raw_client(program, timeout=2.0):
    sock = socket.create_connection(("127.0.0.1", program.port), timeout=timeout)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return sock


def served(sock):
    """True when the server answers `V` on this connection, False when it refused it."""
    sock.sendall(b"V\r")
    received = b""
    while b"\r" not in received:
        chunk = sock.recv(256)
        if not chunk:
            return False
        received += chunk
    return received.startswith(b"V1013\r") or b"V1013\r" in received


def connect_many(program, count):
    """Opens `count` connections; returns the served ones (left open) and how many were refused."""
    clients, refused = [], 0
    for _ in range(count):
        sock = raw_client(program)
        if served(sock):
            clients.append(sock)
        else:
            refused += 1
            sock.close()
    return clients, refused


def read_until(sock, marker, timeout):
    """Reads until `marker` arrives; returns the time it did, None on timeout or EOF."""
    deadline = time.monotonic() + timeout
    tail = b""
    while time.monotonic() < deadline:
        sock.settimeout(max(0.001, deadline - time.monotonic()))
        try:
            chunk = sock.recv(65536)
        except socket.timeout:
            return None
        if not chunk:
            return None
        tail = tail[-16:] + chunk
        if marker in tail:
            return time.monotonic()
    return None


def sdo_latency(sock, timeout=1.0):
    """One raw SDO upload request on `sock`; the seconds until its response, None if none."""
    sent = time.monotonic()
    sock.sendall(SDO_UPLOAD_1000)
    arrived = read_until(sock, SDO_RESPONSE, timeout)
    return None if arrived is None else arrived - sent


def connect(program):
    network = canopen.Network()
    network.NOTIFIER_CYCLE = 0.05
    network.connect(interface="slcan", channel=program.channel, bitrate=500000, sleep_after_open=0)
    node = canopen.RemoteNode(NODE_ID, canopen.ObjectDictionary())
    network.add_node(node)
    return network, node


def upload_u32(node, index, sub):
    return struct.unpack("<I", node.sdo.upload(index, sub).ljust(4, b"\0")[:4])[0]


# --- 1. Output that cannot stop the drive ------------------------------------------------------


def test_closed_stdout_and_stderr_do_not_stop_the_drive():
    program = Program(node_id=255)  # waits for LSS: a bit-rate line to print
    program.proc.stdout.close()
    program.proc.stderr.close()
    try:
        for _ in range(3):  # every connect and leave is a log line on the closed stderr
            network, _ = connect(program)
            network.disconnect()
        network, _ = connect(program)
        lss = network.lss
        lss.send_switch_state_global(lss.CONFIGURATION_STATE)
        lss.configure_node_id(NODE_ID)
        lss.configure_bit_timing(2)
        lss.activate_bit_timing(10)  # a line on the closed stdout
        time.sleep(0.1)
        lss.send_switch_state_global(lss.WAITING_STATE)
        node = canopen.RemoteNode(NODE_ID, canopen.ObjectDictionary())
        network.add_node(node)
        assert upload_u32(node, 0x1000, 0) == 0x0002_0192
        # A hardware fault: the drive reacts, reports it, and goes on serving.
        emcys = []
        network.subscribe(0x80 + NODE_ID, lambda _id, data, _ts: emcys.append(bytes(data)))
        node.sdo.download(0x2100, 0, struct.pack("<I", 1))
        deadline = time.monotonic() + 2
        while not emcys and time.monotonic() < deadline:
            time.sleep(0.01)
        assert emcys, "no EMCY for the fault"
        node.sdo.download(0x2100, 0, struct.pack("<I", 0))
        network.disconnect()
        # New clients are still accepted and served.
        for _ in range(3):
            with raw_client(program) as sock:
                assert served(sock)
        assert program.proc.poll() is None, f"exited with {program.proc.returncode}"
    finally:
        status = program.stop()
    assert status == 0


def test_pipes_nobody_reads_do_not_stop_the_drive():
    """A supervisor that reads up to `ready` and then never again: the pipes fill up."""
    program = Program()
    try:
        # Each connection is two log lines: far more than a pipe holds (64 KiB).
        for _ in range(1500):
            socket.create_connection(("127.0.0.1", program.port)).close()
        with raw_client(program) as sock:
            assert served(sock)
            assert sdo_latency(sock) is not None
    finally:
        status = program.stop()
    assert status == 0


def test_quiet_prints_no_log_lines():
    program = Program("--quiet")
    try:
        with raw_client(program) as sock:
            assert served(sock)
    finally:
        status = program.stop()
    assert status == 0
    assert program.read_stderr(0.2) == ""


# --- 2. Bounded, fair transport ----------------------------------------------------------------

FLOOD_SECONDS = 20
RSS_LIMIT_KB = 32 * 1024


def test_a_flooding_client_neither_starves_the_others_nor_grows_memory():
    program = Program()
    try:
        with raw_client(program) as probe:
            assert served(probe)
            before = [sdo_latency(probe) for _ in range(20)]
            assert None not in before
            rss_before = program.status("VmRSS")

            flood = socket.create_connection(("127.0.0.1", program.port))
            flood.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 1 << 20)
            stop = threading.Event()
            sent = [0]

            def flooding():
                # Frames for nobody in particular, as fast as TCP takes them; the flooding
                # client never reads what it is sent.
                burst = b"t1238DEADBEEF01234567\r" * 4096
                while not stop.is_set():
                    try:
                        flood.sendall(burst)
                    except OSError:
                        return
                    sent[0] += 4096

            thread = threading.Thread(target=flooding, daemon=True)
            thread.start()
            latencies, rss = [], []
            started = time.monotonic()
            while time.monotonic() - started < FLOOD_SECONDS:
                latencies.append(sdo_latency(probe, timeout=2.0))
                rss.append(program.status("VmRSS"))
                time.sleep(0.1)
            stop.set()
            flood.close()
            thread.join(5)
            rss_after = program.status("VmRSS")
            after = [sdo_latency(probe) for _ in range(20)]
    finally:
        status = program.stop()
    log = program.read_stderr(0.5)
    answered = [t for t in latencies if t is not None]
    median = lambda xs: sorted(xs)[len(xs) // 2]  # noqa: E731
    print(
        f"\nflood: {sent[0] / FLOOD_SECONDS / 1e3:.0f} k frames/s offered for {FLOOD_SECONDS} s; "
        f"SDO answered {len(answered)}/{len(latencies)}, median {median(answered) * 1e3:.2f} ms, "
        f"max {max(answered) * 1e3:.1f} ms (before: median {median(before) * 1e3:.2f} ms); "
        f"RSS {rss_before} kB before, max {max(rss)} kB during, {rss_after} kB after"
    )
    assert status == 0
    assert sent[0] > 100_000, "the flood did not flood"
    assert len(answered) == len(latencies), f"{len(latencies) - len(answered)} SDO requests unanswered"
    assert median(answered) < max(0.05, 10 * median(before)), "SDO latency under the flood"
    assert max(answered) < 1.0
    assert None not in after
    assert max(rss) < RSS_LIMIT_KB and rss_after < RSS_LIMIT_KB
    # The loss is the flooding client's own, and it is counted.
    assert "sends faster than the bus carries" in log
    assert "of its frames and" in log


# --- 3. Connection hygiene ---------------------------------------------------------------------


def test_clients_beyond_the_limit_are_refused_and_resources_return():
    program = Program()  # the default limit: 32
    clients = []
    try:
        threads_before = program.status("Threads")
        rss_before = program.status("VmRSS")
        clients, refused = connect_many(program, 100)
        threads_with = program.status("Threads")
        rss_with = program.status("VmRSS")
        for sock in clients:
            sock.close()
        time.sleep(0.5)
        rss_after = program.status("VmRSS")
        with raw_client(program) as sock:
            assert served(sock), "not served after the others left"
            assert sdo_latency(sock) is not None
    finally:
        for sock in clients:
            sock.close()
        status = program.stop()
    print(
        f"\n100 connections: {len(clients)} served, {refused} refused; threads {threads_before} -> "
        f"{threads_with}; RSS {rss_before} kB -> {rss_with} kB with 32 clients -> {rss_after} kB after"
    )
    assert status == 0
    assert len(clients) == 32 and refused == 68
    assert threads_with == threads_before, "a thread per client"
    assert rss_after < rss_before + 4096


def test_the_refusal_says_why():
    program = Program("--max-clients", "1")
    try:
        with raw_client(program) as first, raw_client(program) as second:
            assert served(first)
            text = b""
            while True:
                chunk = second.recv(256)
                if not chunk:
                    break
                text += chunk
    finally:
        assert program.stop() == 0
    assert text.startswith(b"\x07canopen-drive-linux: refused: 1 clients connected"), text


def test_idle_clients_are_disconnected_on_request():
    program = Program("--idle-timeout", "1")
    try:
        with raw_client(program, timeout=10) as idle:
            assert served(idle)
            started = time.monotonic()
            # Until EOF: the drive's own frames may come first (its boot-up, when the client
            # connected before it), but nothing that keeps the client from being idle.
            while chunk := idle.recv(256):
                assert all(line.startswith(b"t7") for line in chunk.split(b"\r") if line), chunk
            waited = time.monotonic() - started
        assert 0.9 <= waited < 5, waited
    finally:
        assert program.stop() == 0
    assert "nothing received for 1 s" in program.read_stderr(0.2)


def test_connections_use_tcp_keepalive():
    if shutil.which("ss") is None:
        pytest.skip("ss (iproute2) is not installed")
    program = Program()
    try:
        with raw_client(program) as sock:
            assert served(sock)
            local_port = sock.getsockname()[1]
            # The server's side of this connection (source port = the server's).
            out = subprocess.run(
                ["ss", "-tnoH", "state", "established", f"( sport = :{program.port} and dport = :{local_port} )"],
                capture_output=True,
                text=True,
                check=True,
            ).stdout
    finally:
        assert program.stop() == 0
    assert "timer:(keepalive" in out, out


def test_the_open_file_limit_refuses_clients_without_a_log_storm():
    def low_limit():
        resource.setrlimit(resource.RLIMIT_NOFILE, (24, 24))

    program = Program("--max-clients", "1000", preexec_fn=low_limit)
    clients = []
    try:
        clients, refused = connect_many(program, 60)
        time.sleep(1.0)  # a storm would be 20 lines in this second
        for sock in clients:
            sock.close()
        time.sleep(0.3)
        with raw_client(program) as sock:
            assert served(sock), "not served after the descriptors came back"
    finally:
        for sock in clients:
            sock.close()
        status = program.stop()
    log = program.read_stderr(0.2)
    reports = log.count("out of file descriptors")
    print(f"\nRLIMIT_NOFILE 24: {len(clients)} served, {refused} refused, {reports} log lines about it")
    assert status == 0
    assert clients and refused > 0
    assert 1 <= reports <= 3, log


# --- 4. Damage reported ------------------------------------------------------------------------


def store_heartbeat_time(path, ms, profile=()):
    program = Program("--storage", str(path), *profile)
    try:
        network, node = connect(program)
        node.sdo.download(0x1017, 0, struct.pack("<H", ms))
        node.sdo.download(0x1010, 1, b"save")
        network.disconnect()
    finally:
        assert program.stop() == 0


def emcy_codes(frames):
    return [struct.unpack("<H", data[:2])[0] for data in frames]


def check_reported(program, path):
    """Started on damaged storage: said so on stderr, defaults, EMCY 6300h in 1001h/1003h and
    sent again after a reset node."""
    assert "not used" in program.read_stderr(0.5) and str(path) in program.stderr_text.decode()
    network, node = connect(program)
    try:
        assert struct.unpack("<H", node.sdo.upload(0x1017, 0))[0] == 0, "defaults"
        assert node.sdo.upload(0x1001, 0)[0] != 0
        assert node.sdo.upload(0x1003, 0)[0] >= 1
        assert upload_u32(node, 0x1003, 1) & 0xFFFF == 0x6300
        emcys = []
        network.subscribe(0x80 + NODE_ID, lambda _id, data, _ts: emcys.append(bytes(data)))
        node.nmt.send_command(0x81)  # reset node
        deadline = time.monotonic() + 2
        while 0x6300 not in emcy_codes(emcys) and time.monotonic() < deadline:
            time.sleep(0.01)
        assert 0x6300 in emcy_codes(emcys), emcys
        assert upload_u32(node, 0x1003, 1) & 0xFFFF == 0x6300
    finally:
        network.disconnect()


@pytest.mark.parametrize("damage", ["contents", "truncated", "empty", "too long"])
def test_damaged_storage_is_reported_and_kept_until_a_store(tmp_path, damage):
    path = tmp_path / "params.bin"
    store_heartbeat_time(path, 100)
    data = bytearray(path.read_bytes())
    if damage == "contents":
        data[40] ^= 0x01
    elif damage == "truncated":
        data = data[:100]
    elif damage == "empty":
        data = bytearray()
    else:
        data += b"\0" * 10
    path.write_bytes(bytes(data))

    program = Program("--storage", str(path))
    try:
        check_reported(program, path)
        assert path.read_bytes() == bytes(data), "the damaged file was changed before a store"
        network, node = connect(program)
        node.sdo.download(0x1017, 0, struct.pack("<H", 200))
        node.sdo.download(0x1010, 1, b"save")
        network.disconnect()
    finally:
        assert program.stop() == 0
    program = Program("--storage", str(path))
    try:
        network, node = connect(program)
        assert struct.unpack("<H", node.sdo.upload(0x1017, 0))[0] == 200
        assert node.sdo.upload(0x1001, 0)[0] == 0
        network.disconnect()
    finally:
        assert program.stop() == 0
    assert "not used" not in program.read_stderr(0.2)


def test_a_profile_never_loads_another_profiles_parameters(tmp_path):
    path = tmp_path / "params.bin"
    store_heartbeat_time(path, 100)  # the generic drive
    program = Program("--storage", str(path), "--profile", "chieftek")
    try:
        assert "another drive" in program.read_stderr(0.5)
        check_reported(program, path)
    finally:
        assert program.stop() == 0

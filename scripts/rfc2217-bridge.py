#!/usr/bin/env python3
"""An RFC 2217 serial device server for tests: pyserial's
serial.rfc2217.PortManager in front of a serial port (here: the pty of
`driveset sim --pty`), one TCP client at a time on 127.0.0.1.

Usage: rfc2217-bridge.py SERIAL_PORT [TCP_PORT]

stdout, one line each, flushed (the test reads them):
    rfc2217 127.0.0.1:PORT                      once, when listening
    connected IP:PORT                           a client connected
    set baud=19200 bytesize=7 parity=E stopbits=1
                                                when a client that set the
                                                line (RFC 2217 SET-BAUDRATE,
                                                -DATASIZE, -PARITY,
                                                -STOPSIZE) leaves: the
                                                settings it left the port in
    disconnected                                the client left

Runs until killed (SIGTERM / SIGINT). Used by the RFC 2217 interop test
(tests/integration/rfc2217.rs); needs pyserial from scripts/setup-python.
"""

import socket
import sys
import termios
import threading

import serial
import serial.rfc2217


class Port(serial.Serial):
    """A serial port as a pty allows it: the modem lines read as inactive
    (a pty refuses TIOCMGET, which PortManager polls), and a framing the
    pty refuses (a Linux pty takes no CS7 / PARENB: it carries 8-bit
    characters whatever is set) is kept as the port's settings, reported
    to the client and printed, while the pty runs 8N1 underneath; the
    simulator does the 7-bit handling."""

    def _reconfigure_port(self, force_update=False):
        try:
            super()._reconfigure_port(force_update)
        except termios.error:
            want = (self._bytesize, self._parity)
            self._bytesize, self._parity = serial.EIGHTBITS, serial.PARITY_NONE
            try:
                super()._reconfigure_port(force_update)
            finally:
                self._bytesize, self._parity = want

    def _line(self, name):
        try:
            return getattr(super(), name)
        except (OSError, serial.SerialException):
            return False

    @property
    def cts(self):
        return self._line("cts")

    @property
    def dsr(self):
        return self._line("dsr")

    @property
    def ri(self):
        return self._line("ri")

    @property
    def cd(self):
        return self._line("cd")


class Manager(serial.rfc2217.PortManager):
    """PortManager that notes whether the client set the line."""

    set_by_client = False

    def _telnet_process_subnegotiation(self, suboption):
        super()._telnet_process_subnegotiation(suboption)
        if suboption[0:1] == serial.rfc2217.COM_PORT_OPTION and suboption[1:2] in (
            serial.rfc2217.SET_BAUDRATE,
            serial.rfc2217.SET_DATASIZE,
            serial.rfc2217.SET_PARITY,
            serial.rfc2217.SET_STOPSIZE,
        ):
            self.set_by_client = True


def settings(ser):
    return "set baud={} bytesize={} parity={} stopbits={}".format(
        ser.baudrate, ser.bytesize, ser.parity, ser.stopbits
    )


def say(line):
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


class Connection:
    """The write side PortManager needs (thread safe)."""

    def __init__(self, sock):
        self.sock = sock
        self.lock = threading.Lock()

    def write(self, data):
        with self.lock:
            self.sock.sendall(data)


def serve(ser, sock):
    conn = Connection(sock)
    manager = Manager(ser, conn)
    alive = [True]

    def serial_to_net():
        while alive[0]:
            try:
                data = ser.read(ser.in_waiting or 1)
            except (serial.SerialException, OSError):
                break
            if data:
                try:
                    conn.write(b"".join(manager.escape(data)))
                except OSError:
                    break

    reader = threading.Thread(target=serial_to_net, daemon=True)
    reader.start()
    try:
        while True:
            data = sock.recv(1024)
            if not data:
                break
            out = b"".join(manager.filter(data))
            if out:
                ser.write(out)
    except OSError as e:
        sys.stderr.write("bridge: connection ended: {}\n".format(e))
    finally:
        alive[0] = False
        reader.join(2)
        sock.close()
        if manager.set_by_client:
            say(settings(ser))


def main():
    if len(sys.argv) not in (2, 3):
        sys.stderr.write(__doc__)
        return 2
    ser = Port(sys.argv[1], timeout=0.05)
    listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    listener.bind(("127.0.0.1", int(sys.argv[2]) if len(sys.argv) == 3 else 0))
    listener.listen(1)
    say("rfc2217 127.0.0.1:{}".format(listener.getsockname()[1]))
    while True:
        sock, peer = listener.accept()
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        say("connected {}:{}".format(*peer))
        serve(ser, sock)
        say("disconnected")


if __name__ == "__main__":
    try:
        sys.exit(main())
    except KeyboardInterrupt:
        sys.exit(0)

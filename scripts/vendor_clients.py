"""The vendors' own client libraries against `tmo sim serve` (issue 7: the emulated devices
follow the published protocols closely enough that they work, not only tmo's own drivers).

    python vendor_clients.py SERVED_HARDWARE.toml

- JeVois: pyserial reads the fingertip cameras' `F2` lines and the marker camera's `D3` lines.
- Dynamixel: ROBOTIS DynamixelSDK pings each servo, sync-writes goal positions and
  sync-reads present positions until the fingers get there.
- UR: SDU's ur_rtde RTDEReceiveInterface streams timestamp and actual_TCP_pose over RTDE
  (it always uses port 30004: serve with --ur-address), while a `movel` line sent to the
  secondary interface moves the tool up 10 mm.

Prints what each client saw; exits 1 with the reason on the first failure.
"""

import socket
import sys
import time
import tomllib

import serial
import dynamixel_sdk as dxl
import rtde_receive

ADDR_GOAL_POSITION = 116
ADDR_PRESENT_POSITION = 132


def fail(why):
    print(f"FAIL: {why}")
    sys.exit(1)


def jevois(hw):
    pins = hw["cameras"].get("pins", 30)
    for k, cam in enumerate(hw["cameras"]["fingertips"]):
        with serial.Serial(cam["port"], cam["baud"], timeout=2.0) as port:
            port.reset_input_buffer()
            good = 0
            for _ in range(50):
                words = port.readline().decode("ascii", "replace").split()
                if len(words) >= 3 and words[0] == "F2" and int(words[2]) == pins:
                    assert len(words) == 3 + 2 * pins, words
                    [float(w) for w in words[3:]]
                    good += 1
                if good >= 10:
                    break
            if good < 10:
                fail(f"fingertip camera {k}: {good} F2 lines of {pins} pins in 50")
    m = hw["marker_camera"]
    seen = set()
    with serial.Serial(m["port"], m["baud"], timeout=2.0) as port:
        for _ in range(40):
            words = port.readline().decode("ascii", "replace").split()
            if len(words) == 12 and words[0] == "D3":
                seen.add(words[1])
    if {m["object_marker"], m["hand_marker"]} - seen:
        fail(f"marker camera: saw {seen}")
    print(f"jevois: {len(hw['cameras']['fingertips'])} fingertip cameras, markers {sorted(seen)}")


def dynamixel(hw):
    h = hw["hand"]
    port = dxl.PortHandler(h["port"])
    if not port.openPort() or not port.setBaudRate(h["baud"]):
        fail(f"cannot open {h['port']} at {h['baud']}")
    packets = dxl.PacketHandler(2.0)
    for i in h["ids"]:
        model, result, error = packets.ping(port, i)
        if result != dxl.COMM_SUCCESS or error:
            fail(f"ping {i}: {packets.getTxRxResult(result)} {packets.getRxPacketError(error)}")
    # goal 30 % of the way from open (min) to closed (max) on the three fingers
    goals = [round(lo + 0.3 * (hi - lo)) for lo, hi in zip(h["min"], h["max"])][:3]
    write = dxl.GroupSyncWrite(port, packets, ADDR_GOAL_POSITION, 4)
    for i, g in zip(h["ids"], goals):
        write.addParam(i, list(g.to_bytes(4, "little")))
    if write.txPacket() != dxl.COMM_SUCCESS:
        fail("sync write of goal positions")
    read = dxl.GroupSyncRead(port, packets, ADDR_PRESENT_POSITION, 4)
    for i in h["ids"][:3]:
        read.addParam(i)
    deadline = time.time() + 10
    while True:
        result = read.txRxPacket()
        if result != dxl.COMM_SUCCESS:
            fail(f"sync read: {packets.getTxRxResult(result)}")
        now = [read.getData(i, ADDR_PRESENT_POSITION, 4) for i in h["ids"][:3]]
        if all(abs(n - g) <= 2 for n, g in zip(now, goals)):
            break
        if time.time() > deadline:
            fail(f"fingers at {now}, goals {goals}")
        time.sleep(0.05)
    port.closePort()
    print(f"dynamixel: pinged {h['ids']}, fingers at {now} (goals {goals})")


def ur(hw):
    host = hw["arm"]["host"]
    if hw["arm"].get("rtde_port", 30004) != 30004:
        fail("ur_rtde needs RTDE on port 30004: serve with --ur-address")
    r = rtde_receive.RTDEReceiveInterface(host, 125.0, ["timestamp", "actual_TCP_pose"])
    t0, pose0 = r.getTimestamp(), r.getActualTCPPose()
    x, y, z, rx, ry, rz = pose0
    with socket.create_connection((host, hw["arm"].get("script_port", 30002)), timeout=5) as s:
        s.sendall(f"movel(p[{x},{y},{z + 0.010},{rx},{ry},{rz}], a=0.5, v=0.05)\n".encode())
        deadline = time.time() + 10
        while r.getActualTCPPose()[2] < z + 0.0099:
            if time.time() > deadline:
                fail(f"tool at z {r.getActualTCPPose()[2]:.4f} m, asked for {z + 0.010:.4f}")
            time.sleep(0.02)
    t1, z1 = r.getTimestamp(), r.getActualTCPPose()[2]
    if not t1 > t0:
        fail(f"timestamp did not advance: {t0} -> {t1}")
    r.disconnect()
    print(f"ur_rtde: timestamp {t0:.3f} -> {t1:.3f} s, tool z {z:.4f} -> {z1:.4f} m")


if __name__ == "__main__":
    with open(sys.argv[1], "rb") as f:
        hardware = tomllib.load(f)
    jevois(hardware)
    dynamixel(hardware)
    ur(hardware)
    print("ok")

"""The vendor's own 2DIY client, HaplyHAPI 1.0.1, for tests/haply2diy.rs.

    python haply_vendor.py drive PORT FORCES_JSON
        sets the board up as the vendor's README example does for hardware
        v3 (device id 5), then for each force [fx, fy]: torques from the
        Jacobian at the last angles read, written, the reply read; prints
        the angles read back, as JSON.
    python haply_vendor.py kinematics ANGLES_JSON FORCES_JSON
        the Pantograph (v3) forward kinematics at each pair of angles and
        the torques for each force there, as JSON: [[x, y, tau1, tau2], ...]
        per angle pair, per force.
"""
import json
import sys

from HaplyHAPI import Board, Device, Pantograph

CW = 0
CCW = 1


def drive(port, forces):
    board = Board("frictionlab-peer", port, 115200)
    device = Device(5, board)
    device.set_mechanism(Pantograph(3))
    device.add_actuator(1, CCW, 2)
    device.add_actuator(2, CCW, 1)
    device.add_encoder(1, CCW, 168, 4880, 2)
    device.add_encoder(2, CCW, 12, 4880, 1)
    device.device_set_parameters()
    read = []
    for f in forces:
        device.set_device_torques(f)
        device.device_write_torques()
        device.device_read_data()
        angles = device.get_device_angles()
        device.get_device_position(angles)
        read.append([float(a) for a in angles])
    print(json.dumps(read))


def kinematics(angles, forces):
    out = []
    for a in angles:
        p = Pantograph(3)
        p.forwardKinematics(a)
        x, y = p.get_coordinate()
        row = []
        for f in forces:
            p.torqueCalculation(f)
            t1, t2 = p.get_torque()
            row.append([x, y, t1, t2])
        out.append(row)
    print(json.dumps(out))


if __name__ == "__main__":
    if sys.argv[1] == "drive":
        drive(sys.argv[2], json.loads(sys.argv[3]))
    else:
        kinematics(json.loads(sys.argv[2]), json.loads(sys.argv[3]))

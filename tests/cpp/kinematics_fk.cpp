// kinematics_fk.cpp -- prints the kinematics library's FK of a URDF for joint values read from
// stdin, so that tests/python/robot/test_fk_numpy.py can compare it with numpy.
//   kinematics_fk URDF [BASE TIP] < lines of 6 joint values (rad)
// prints, per line, the 4x4 homogeneous transform of TIP in BASE, row by row (16 numbers), or
// "error: ..." and exit status 1 when the URDF does not load.
#include <indurop/kinematics/robot.hpp>

#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>

int main(int argc, char **argv) {
    if (argc != 2 && argc != 4) {
        std::fprintf(stderr, "usage: kinematics_fk URDF [BASE TIP] < joint values\n");
        return 2;
    }
    auto robot = argc == 4 ? irp::kin::Robot::load(argv[1], argv[2], argv[3]) : irp::kin::Robot::load(argv[1]);
    if (!robot) {
        std::printf("error: %s\n", robot.error().message.c_str());
        return 1;
    }
    std::string line;
    while (std::getline(std::cin, line)) {
        std::istringstream in(line);
        irp::kin::Joints q;
        for (int i = 0; i < irp::kin::kAxes; ++i) in >> q[i];
        if (!in) continue;
        irp::kin::Pose p = robot->fk(q);
        Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
        T.topLeftCorner<3, 3>() = p.rotation();
        T.topRightCorner<3, 1>() = p.position;
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) std::printf("%.17g%c", T(r, c), r == 3 && c == 3 ? '\n' : ' ');
    }
    return 0;
}

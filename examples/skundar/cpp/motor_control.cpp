// Rob0MotorControl: turn DiffMotion commands into wheel speeds for Skundar's two motors.
//
// Woken by `Skundar.Output.Motor.DiffMotion` (v m/s, w rad/s, from the Java Rob0MotionControl)
// on MotorWB, it computes the wheel speeds of the differential drive, scales both down when
// one would exceed the motors' limit, and posts `Skundar.Output.Motor.WheelSpeeds` (l, r m/s)
// to MotorWB, where the simulated plant takes them. A watchdog stops the motors when no
// command came for 500 ms (a controller that died or fell behind must not leave them running).
//
// Exit status: 0 when stopped by SIGTERM/SIGINT, 2 on an error.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>

#include "openair/client.hpp"
#include "skundar.hpp"

namespace {

constexpr double wheel_base = 0.30;  // m
constexpr double max_wheel = 0.45;   // m/s
constexpr auto watchdog = std::chrono::milliseconds(500);

struct wheels {
    double left;
    double right;
    std::string content;
};

wheels wheels_for(const std::string& diff) {
    auto v = skundar::kv(diff);
    double speed = skundar::number(v, "v");
    double turn = skundar::number(v, "w");
    double left = speed - turn * wheel_base / 2;
    double right = speed + turn * wheel_base / 2;
    double scale = std::max({1.0, std::abs(left) / max_wheel, std::abs(right) / max_wheel});
    left /= scale;
    right /= scale;
    return {left, right,
            "l=" + skundar::fixed(left) + ";r=" + skundar::fixed(right) + ";t=" + v["t"] +
                ";seq=" + v["seq"]};
}

}  // namespace

int main() {
    skundar::handle_signals();
    openair::client_options options;
    skundar::address(options.host, options.port);
    options.name = "Rob0MotorControl";
    try {
        openair::client motors = openair::client::connect(options);
        auto last = std::chrono::steady_clock::now();
        bool moving = false;
        motors.on_wakeup([&](const openair::wakeup_event& event) {
            if (!event.wakeup.trigger) return;  // a phase update (OA-WAKE-8)
            wheels w = wheels_for(event.wakeup.trigger->content);
            motors.post("MotorWB", "Skundar.Output.Motor.WheelSpeeds", w.content);
            last = std::chrono::steady_clock::now();
            moving = w.left != 0.0 || w.right != 0.0;
        });
        motors.subscribe({openair::trigger{"Skundar.Output.Motor.DiffMotion", "MotorWB", 0, ""}});
        std::cout << "ready" << std::endl;
        while (skundar::running) {
            motors.poll(std::chrono::milliseconds(50));
            if (moving && std::chrono::steady_clock::now() - last > watchdog) {
                motors.post("MotorWB", "Skundar.Output.Motor.WheelSpeeds", "l=0;r=0;watchdog=1");
                moving = false;
                std::cerr << "Rob0MotorControl: watchdog stop" << std::endl;
            }
        }
        motors.close();
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "Rob0MotorControl: " << e.what() << std::endl;
        return 2;
    }
}

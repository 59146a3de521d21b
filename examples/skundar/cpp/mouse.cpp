// Rob0Mouse (Figure 1): Skundar's optical-mouse driver.
//
// Woken at 10 Hz by the sensor hardware's sample (`Skundar.Sim.MouseSensor` on SimWB: counts
// at 400 per inch in the robot's frame, the gyro's heading change in microradians), it posts
// the motion in metres and radians as `Skundar.Input.Sens.MouseMotion` to PerceptionWB,
// passing on the sample's time `t` and number `seq`. In Figure 2 this module is gone: the
// merged Mouse+Tracker runs inside the server.
//
// Exit status: 0 when stopped by SIGTERM/SIGINT, 2 on an error.
#include <chrono>
#include <iostream>

#include "openair/client.hpp"
#include "skundar.hpp"

namespace {

constexpr double counts_per_m = 400.0 / 0.0254;
constexpr double gyro_per_rad = 1e6;

std::string motion_of(const std::string& sensor) {
    auto v = skundar::kv(sensor);
    return "dx=" + skundar::fixed(skundar::number(v, "cx") / counts_per_m) +
           ";dy=" + skundar::fixed(skundar::number(v, "cy") / counts_per_m) +
           ";dth=" + skundar::fixed(skundar::number(v, "gz") / gyro_per_rad) + ";t=" + v["t"] +
           ";seq=" + v["seq"];
}

}  // namespace

int main() {
    skundar::handle_signals();
    openair::client_options options;
    skundar::address(options.host, options.port);
    options.name = "Rob0Mouse";
    try {
        openair::client mouse = openair::client::connect(options);
        mouse.on_wakeup([&mouse](const openair::wakeup_event& event) {
            if (!event.wakeup.trigger) return;  // a phase update (OA-WAKE-8)
            mouse.post("PerceptionWB", "Skundar.Input.Sens.MouseMotion",
                       motion_of(event.wakeup.trigger->content));
        });
        mouse.subscribe({openair::trigger{"Skundar.Sim.MouseSensor", "SimWB", 0, ""}});
        std::cout << "ready" << std::endl;
        while (skundar::running) mouse.poll(std::chrono::milliseconds(100));
        mouse.close();
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "Rob0Mouse: " << e.what() << std::endl;
        return 2;
    }
}

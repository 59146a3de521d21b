package org.openair.skundar;

import java.util.HashMap;
import java.util.List;
import java.util.Locale;
import java.util.Map;
import java.util.concurrent.CountDownLatch;
import org.openair.Message;
import org.openair.Module;
import org.openair.OpenAir;
import org.openair.OpenAirException;
import org.openair.Options;
import org.openair.Registration;
import org.openair.Trigger;
import org.openair.Wakeup;

/**
 * Rob0MotionControl: Skundar's motion controller (seed paper, Figure 1), in Java.
 *
 * <p>Subscribed to {@code Skundar.Input.Perc.Track} (the tracked pose, 10 Hz) on PerceptionWB and
 * {@code Skundar.Decision.Cmd2dMove} (the goal) on DecisionWB. On every Track it runs the fuzzy
 * controller towards the goal and posts {@code Skundar.Output.Motor.DiffMotion} (v, w) to MotorWB
 * for Rob0MotorControl. Each command carries the sensor sample's time {@code t} and number
 * {@code seq}, its loop latency {@code lat} (ms from the sample to this command) and
 * {@code late=1} when that exceeded the loop deadline ({@code SKUNDAR_DEADLINE_MS}, by default
 * 100 ms: the sensor period, the command must leave before the next sample is taken).
 *
 * <p>Run: {@code java -cp target/classes:openair.jar org.openair.skundar.MotionControl}; the
 * server is {@code SKUNDAR_HOST}:{@code SKUNDAR_PORT}. Prints {@code ready} once registered;
 * stops on SIGTERM. Exit status 1 on an OpenAIR failure.
 */
public final class MotionControl {
    private double goalX;
    private double goalY;
    private boolean hasGoal;
    private final double deadlineMs;
    private final Module[] module = new Module[1];

    private MotionControl(double deadlineMs) {
        this.deadlineMs = deadlineMs;
    }

    static Map<String, String> kv(String content) {
        Map<String, String> out = new HashMap<>();
        for (String part : content.split(";")) {
            int eq = part.indexOf('=');
            if (eq > 0) {
                out.put(part.substring(0, eq).trim(), part.substring(eq + 1).trim());
            }
        }
        return out;
    }

    private void onWakeup(Wakeup wakeup) {
        Message m = wakeup.trigger();
        if (m == null) {
            return; // a phase update (OA-WAKE-8)
        }
        Map<String, String> v = kv(m.content());
        if (m.type().equals("Skundar.Decision.Cmd2dMove")) {
            goalX = Double.parseDouble(v.get("x"));
            goalY = Double.parseDouble(v.get("y"));
            hasGoal = true;
            return;
        }
        double x = Double.parseDouble(v.get("x"));
        double y = Double.parseDouble(v.get("y"));
        double th = Double.parseDouble(v.get("th"));
        FuzzyController.Command c = new FuzzyController.Command(0.0, 0.0);
        if (hasGoal) {
            double bearing = Math.atan2(goalY - y, goalX - x);
            double error = Math.atan2(Math.sin(bearing - th), Math.cos(bearing - th));
            c = FuzzyController.decide(Math.hypot(goalX - x, goalY - y), error);
        }
        double lat = System.currentTimeMillis() - Double.parseDouble(v.get("t"));
        String content = String.format(Locale.ROOT, "v=%.6f;w=%.6f;t=%s;seq=%s;lat=%.3f;late=%d",
                c.v(), c.w(), v.get("t"), v.get("seq"), lat, lat > deadlineMs ? 1 : 0);
        module[0].post("MotorWB", "Skundar.Output.Motor.DiffMotion", content);
    }

    /**
     * Run the controller until SIGTERM.
     *
     * @param args ignored
     */
    public static void main(String[] args) throws InterruptedException {
        String host = System.getenv().getOrDefault("SKUNDAR_HOST", "127.0.0.1");
        int port = Integer.parseInt(System.getenv().getOrDefault("SKUNDAR_PORT", "10000"));
        double deadline = Double.parseDouble(
                System.getenv().getOrDefault("SKUNDAR_DEADLINE_MS", "100"));
        MotionControl control = new MotionControl(deadline);
        Options options = Options.builder("Rob0MotionControl").server(host, port)
                .wakeupListener(control::onWakeup).build();
        CountDownLatch stop = new CountDownLatch(1);
        try (Module m = OpenAir.connect(options)) {
            control.module[0] = m;
            Runtime.getRuntime().addShutdownHook(new Thread(stop::countDown));
            m.subscribe(new Registration(List.of(
                    Trigger.on("PerceptionWB", "Skundar.Input.Perc.Track"),
                    Trigger.on("DecisionWB", "Skundar.Decision.Cmd2dMove")), List.of(), false));
            System.out.println("ready");
            System.out.flush();
            stop.await();
        } catch (OpenAirException e) {
            System.err.println("Rob0MotionControl: " + e.getMessage());
            System.exit(1);
        }
    }
}

package org.openair.skundar;

/**
 * Skundar's fuzzy speed and direction control (seed paper, Figure 1: Rob0MotionControl).
 *
 * <p>Two inputs, fuzzified with triangular and shoulder sets: the distance to the goal (NEAR,
 * MID, FAR) and the heading error (goal bearing minus heading, radians, left positive: BIG_RIGHT,
 * RIGHT, AHEAD, LEFT, BIG_LEFT). Rules map them to singleton outputs, defuzzified by the
 * weighted mean (Sugeno): the turn rate follows the heading error; the speed follows the
 * distance and is cut while the goal is not ahead.
 */
public final class FuzzyController {
    /** Within this distance (m) the goal counts as reached and the robot stops. */
    public static final double TOLERANCE = 0.04;

    /** A command: forward speed (m/s) and turn rate (rad/s). */
    public record Command(double v, double w) {}

    private FuzzyController() {}

    static double tri(double x, double a, double b, double c) {
        if (x <= a || x >= c) {
            return 0.0;
        }
        return x < b ? (x - a) / (b - a) : (c - x) / (c - b);
    }

    static double up(double x, double a, double b) {
        return x <= a ? 0.0 : x >= b ? 1.0 : (x - a) / (b - a);
    }

    static double down(double x, double a, double b) {
        return 1.0 - up(x, a, b);
    }

    /**
     * Decide one command.
     *
     * @param distance distance to the goal, m
     * @param error heading error, rad in (-pi, pi], positive when the goal is to the left
     * @return the command
     */
    public static Command decide(double distance, double error) {
        if (distance < TOLERANCE) {
            return new Command(0.0, 0.0);
        }
        double near = down(distance, 0.05, 0.35);
        double mid = tri(distance, 0.1, 0.4, 0.9);
        double far = up(distance, 0.5, 1.0);
        double bigRight = down(error, -1.2, -0.5);
        double right = tri(error, -1.0, -0.4, 0.0);
        double ahead = tri(error, -0.35, 0.0, 0.35);
        double left = tri(error, 0.0, 0.4, 1.0);
        double bigLeft = up(error, 0.5, 1.2);
        // Turn: IF error is X THEN w is W(X).
        double w = (bigRight * -1.6 + right * -0.8 + left * 0.8 + bigLeft * 1.6)
                / Math.max(1e-9, bigRight + right + ahead + left + bigLeft);
        // Speed: IF distance is D AND error is AHEAD THEN v is V(D); IF error is (BIG_)LEFT or
        // (BIG_)RIGHT THEN v is SLOW (turn mostly on the spot).
        double aligned = ahead;
        double turning = Math.max(Math.max(right, left), Math.max(bigRight, bigLeft));
        double v = (Math.min(near, aligned) * 0.08 + Math.min(mid, aligned) * 0.2
                + Math.min(far, aligned) * 0.35 + turning * 0.02)
                / Math.max(1e-9, Math.min(near, aligned) + Math.min(mid, aligned)
                        + Math.min(far, aligned) + turning);
        return new Command(v, w);
    }
}

package org.openair;

/**
 * A point in time as OpenAIR carries it (spec section 4): Unix seconds, milliseconds within the
 * second and, under the {@code usec} extension, microseconds within the millisecond (OA-TIME-5).
 *
 * <p>Threading: immutable value; safe to share between threads.
 *
 * @param sec Unix seconds (any signed 64-bit value, OA-TIME-1)
 * @param msec milliseconds within the second, 0-999
 * @param usec microseconds within the millisecond, 0-999, or {@code null} when absent
 */
public record AirTime(long sec, int msec, Integer usec) implements Comparable<AirTime> {

    /*
     * Check the ranges (OA-TIME-1, OA-TIME-6).
     *
     * @throws IllegalArgumentException when msec or usec is outside 0-999
     */
    public AirTime {
        if (msec < 0 || msec > 999) {
            throw new IllegalArgumentException("msec out of range 0-999: " + msec);
        }
        if (usec != null && (usec < 0 || usec > 999)) {
            throw new IllegalArgumentException("usec out of range 0-999: " + usec);
        }
    }

    /**
     * Build a time without microseconds.
     *
     * @param sec Unix seconds
     * @param msec milliseconds within the second
     * @return the time
     */
    public static AirTime of(long sec, int msec) {
        return new AirTime(sec, msec, null);
    }

    /**
     * Build a time from nanoseconds since the epoch.
     *
     * @param nanos nanoseconds since the epoch
     * @param withUsec whether to keep the microseconds (only under the {@code usec} extension)
     * @return the time
     */
    public static AirTime ofEpochNanos(long nanos, boolean withUsec) {
        long sec = Math.floorDiv(nanos, 1_000_000_000L);
        long rest = Math.floorMod(nanos, 1_000_000_000L);
        int msec = (int) (rest / 1_000_000L);
        Integer usec = withUsec ? (int) (rest / 1_000L % 1000L) : null;
        return new AirTime(sec, msec, usec);
    }

    /**
     * Build a time from milliseconds since the epoch.
     *
     * @param millis milliseconds since the epoch
     * @return the time
     */
    public static AirTime ofEpochMillis(long millis) {
        return new AirTime(Math.floorDiv(millis, 1000L), (int) Math.floorMod(millis, 1000L), null);
    }

    /** @return milliseconds since the epoch (microseconds dropped) */
    public long toEpochMillis() {
        return sec * 1000L + msec;
    }

    @Override
    public int compareTo(AirTime other) {
        int c = Long.compare(sec, other.sec);
        if (c == 0) {
            c = Integer.compare(msec, other.msec);
        }
        if (c == 0) {
            c = Integer.compare(usec == null ? 0 : usec, other.usec == null ? 0 : other.usec);
        }
        return c;
    }
}

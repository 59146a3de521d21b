package org.openair;

import java.time.Duration;
import java.util.Optional;

/**
 * Stream alarms as they are posted (OA-XSTREAM-6), received by a companion module
 * ({@code <module>-alarms-<n>}, bound with BIND_NOLISTEN) whose registration is one trigger on the
 * alarm pattern, so that the caller's own registration and wakeups are untouched.
 *
 * <p>Threading: thread-safe; {@link #next} blocks the calling thread only.
 */
public interface AlarmSubscription extends AutoCloseable {
    /**
     * Take the next alarm.
     *
     * @param timeout how long to wait
     * @return the alarm, or empty after the timeout or once closed
     */
    Optional<StreamAlarm> next(Duration timeout);

    /** Disconnect the companion module. */
    @Override
    void close();
}

package org.openair.internal;

import java.time.Duration;
import java.util.Optional;
import java.util.concurrent.atomic.AtomicInteger;
import org.openair.AlarmSubscription;
import org.openair.Module;
import org.openair.OpenAir;
import org.openair.Options;
import org.openair.Registration;
import org.openair.StreamAlarm;
import org.openair.Trigger;
import org.openair.Wakeup;

/**
 * {@link AlarmSubscription} through a companion module {@code <module>-alarms-<n>} (BIND_NOLISTEN,
 * callback connection, no announcement) whose registration is one trigger on the alarm pattern
 * (OA-XSTREAM-6), so that the caller's registration is left as it is.
 *
 * <p>Threading: thread-safe; the companion module's threads receive the wakeups.
 */
final class AlarmSubscriptionImpl implements AlarmSubscription {
    private static final AtomicInteger COMPANIONS = new AtomicInteger();

    private final Module companion;

    AlarmSubscriptionImpl(Options owner, String pattern, String whiteboard) {
        Options o = owner.toBuilder()
                .name(owner.name() + "-alarms-" + COMPANIONS.incrementAndGet())
                .listen(false).announce(false).reconnect(false)
                .wakeupListener(null).messageListener(null).connectionListener(null)
                .build();
        companion = OpenAir.connect(o);
        try {
            companion.subscribe(Registration.of(new Trigger(pattern, whiteboard, 0)));
        } catch (RuntimeException e) {
            companion.close();
            throw e;
        }
    }

    @Override
    public Optional<StreamAlarm> next(Duration timeout) {
        long deadline = System.nanoTime() + timeout.toNanos();
        while (true) {
            long left = Math.max(0, deadline - System.nanoTime());
            Optional<Wakeup> w = companion.nextWakeup(Duration.ofNanos(left));
            if (w.isEmpty()) {
                return Optional.empty();
            }
            if (w.get().trigger() != null && StreamWire.isAlarm(w.get().trigger())) {
                return Optional.of(StreamWire.alarmOf(w.get().trigger())); // not a phase update
            }
        }
    }

    @Override
    public void close() {
        companion.close();
    }
}

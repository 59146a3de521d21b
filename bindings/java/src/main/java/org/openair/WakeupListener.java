package org.openair;

/**
 * Receives the module's wakeups, phase updates included.
 *
 * <p>Threading: called only on the module's one dispatcher thread (named
 * {@code openair-<name>-dispatch}), one wakeup at a time, in the order the library received them.
 * A listener may call the module's blocking methods (post, retrieve, ...): replies are read by
 * other threads. While it runs, further wakeups wait in a bounded queue, and a full queue holds
 * back the acknowledgements of new deliveries. An exception thrown by the listener is reported to
 * the {@link ConnectionListener} and does not stop the dispatcher.
 */
@FunctionalInterface
public interface WakeupListener {
    /**
     * Handle one wakeup.
     *
     * @param wakeup the wakeup
     */
    void onWakeup(Wakeup wakeup);
}

package org.openair;

/**
 * Receives messages forwarded to the module by name (OA-SESS-22).
 *
 * <p>Threading: called only on the module's one dispatcher thread, like {@link WakeupListener},
 * interleaved with the wakeups in the order the library received them.
 */
@FunctionalInterface
public interface MessageListener {
    /**
     * Handle one delivered message.
     *
     * @param delivery the delivery
     */
    void onMessage(Delivery delivery);
}

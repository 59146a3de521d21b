package org.openair;

/**
 * Hears about the module's connection: (re)connections, losses and failures that no caller could
 * be told about. Every method has a no-op default.
 *
 * <p>Threading: called only on the module's one dispatcher thread, in order with the wakeups.
 */
public interface ConnectionListener {
    /**
     * The module is connected and set up (bound, registration re-sent after a reconnect).
     *
     * @param generation 1 for the first connection, then one more for each reconnection
     */
    default void onConnected(int generation) {}

    /**
     * The primary connection was lost; the module reconnects if its options say so.
     *
     * @param cause why, or {@code null} when the server closed the connection cleanly
     */
    default void onDisconnected(OpenAirException cause) {}

    /**
     * Something failed in the background: a delivery connection broke, a listener threw, a
     * reconnection attempt failed.
     *
     * @param error what went wrong
     */
    default void onError(Throwable error) {}
}

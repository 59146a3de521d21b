package org.openair;

/**
 * Which connection carried a delivery (OA-DELIV-1): the callback connection the module opened, or
 * a connection the server opened to the module's listening port.
 *
 * <p>Threading: an enum; safe to share between threads.
 */
public enum DeliveryPath {
    /** The callback connection (spec 6.5). */
    CALLBACK,
    /** A connection to the listening port of BIND_ACCEPT (spec 6.6). */
    LISTENER
}

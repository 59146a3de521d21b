package org.openair;

/**
 * A lock on a range of sample ids (LOCK_SAMPLES, OA-XSTREAM-5), released by {@link #close()}
 * (UNLOCK_SAMPLES): {@code try (StreamLock lock = stream.lock(1, 9)) { … }}. The lock belongs to
 * its handle's connection; the server releases it when that connection closes.
 *
 * <p>Threading: thread-safe; closing twice releases once.
 */
public interface StreamLock extends AutoCloseable {
    /** @return the lock id the stream gave out */
    long lockId();

    /** @return the first id of the range */
    long first();

    /** @return the last id of the range */
    long last();

    /**
     * Release the lock (UNLOCK_SAMPLES); a second call does nothing.
     *
     * @throws RequestFailedException when the stream no longer knows the lock (LOCK_UNKNOWN)
     * @throws ConnectionClosedException when the handle's connection (and so the lock) is gone
     */
    @Override
    void close();
}

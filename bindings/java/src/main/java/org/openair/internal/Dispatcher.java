package org.openair.internal;

import java.util.concurrent.ArrayBlockingQueue;
import java.util.concurrent.BlockingQueue;
import java.util.concurrent.TimeUnit;
import java.util.function.Consumer;

/**
 * The module's one dispatcher thread: runs the listeners' callbacks in order, one at a time.
 * A bounded queue holds the tasks; a full queue blocks the delivery thread that submits, which
 * holds back that delivery's acknowledgement (back pressure towards the server).
 *
 * <p>Threading: {@link #submit} may be called from any thread; tasks run on the thread named
 * {@code openair-<name>-dispatch}.
 */
final class Dispatcher {
    private static final Runnable STOP = () -> { };

    private final BlockingQueue<Runnable> queue;
    private final Thread thread;
    private final Consumer<Throwable> onError;
    private volatile boolean closed;

    Dispatcher(String name, int capacity, Consumer<Throwable> onError) {
        this.queue = new ArrayBlockingQueue<>(capacity);
        this.onError = onError;
        this.thread = new Thread(this::run, "openair-" + name + "-dispatch");
        thread.setDaemon(true);
        thread.start();
    }

    private void run() {
        while (true) {
            Runnable task;
            try {
                task = queue.take();
            } catch (InterruptedException e) {
                return;
            }
            if (task == STOP) {
                return;
            }
            try {
                task.run();
            } catch (RuntimeException | Error e) {
                onError.accept(e); // a failing listener does not stop the dispatcher
            }
        }
    }

    /** @return whether the caller is the dispatcher thread */
    boolean isDispatcherThread() {
        return Thread.currentThread() == thread;
    }

    /**
     * Queue a task, waiting while the queue is full.
     *
     * @param task the task
     * @throws InterruptedException when interrupted while waiting
     */
    void submit(Runnable task) throws InterruptedException {
        if (isDispatcherThread()) {
            if (!queue.offer(task)) {
                task.run(); // never block the dispatcher on itself
            }
            return;
        }
        while (!closed) { // a closed dispatcher takes nothing more: do not wait for it forever
            if (queue.offer(task, 100, TimeUnit.MILLISECONDS)) {
                return;
            }
        }
    }

    /** Try to queue a task without waiting; drop it when the queue is full. */
    void offer(Runnable task) {
        queue.offer(task);
    }

    /** Drop the queued tasks and stop; waits briefly unless called from the dispatcher. */
    void close() {
        closed = true;
        queue.clear();
        queue.offer(STOP);
        if (!isDispatcherThread()) {
            thread.interrupt();
            try {
                thread.join(2000);
            } catch (InterruptedException e) {
                Thread.currentThread().interrupt();
            }
        }
    }
}

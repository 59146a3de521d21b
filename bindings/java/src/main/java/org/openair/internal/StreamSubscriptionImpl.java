package org.openair.internal;

import java.lang.System.Logger.Level;
import java.net.Socket;
import java.time.Duration;
import java.util.Optional;
import java.util.Set;
import java.util.TreeSet;
import java.util.concurrent.Flow;
import java.util.concurrent.LinkedBlockingQueue;
import java.util.concurrent.Semaphore;
import java.util.concurrent.TimeUnit;
import java.util.concurrent.atomic.AtomicLong;
import org.openair.ApiMisuseException;
import org.openair.ConnectionClosedException;
import org.openair.DataSample;
import org.openair.DeliveryPath;
import org.openair.Message;
import org.openair.OpenAirException;
import org.openair.ReceivedSample;
import org.openair.RequestFailedException;
import org.openair.RequestTimeoutException;
import org.openair.SampleListener;
import org.openair.Slot;
import org.openair.StreamSubscription;

/**
 * One push connection (spec 11.6, OA-STREAM-8): a {@code Receive} frame RECEIVE_NAME_NOTIFICATION
 * whose {@code to} is the stream's name or type, after which the server is the requester
 * (OA-SESS-28) and sends each new sample as DATASAMPLE. Each sample is acknowledged once it is in
 * the local buffer ({@code buffer} samples): a consumer that falls behind holds the
 * acknowledgements back, and the server then drops samples for this subscriber only and reports
 * them in the next sample's {@code dropped} slot. Nothing answers a notification that worked, so
 * {@link #open()} confirms the subscription by asking GET_INFO until {@code subscribers} grows.
 *
 * <p>Threading: the connection's reader thread (a {@link DeliveryConnection}) buffers samples;
 * with a listener or a Flow subscriber one delivery thread per subscription hands them over, in
 * order; otherwise {@link #next} takes them on the caller's thread.
 */
final class StreamSubscriptionImpl implements StreamSubscription {
    private static final System.Logger LOG = System.getLogger("org.openair");
    private static final ReceivedSample END = new ReceivedSample("", DataSample.of(new byte[0]),
            0, 0);
    private static final long FIRST_DELAY_MS = 1;
    private static final long MAX_DELAY_MS = 50;

    /** Ends the push connection without answering the server's refusal. */
    private static final class Refused extends RuntimeException {
        private static final long serialVersionUID = 1L;

        Refused() {
            super("subscription refused", null, false, false);
        }
    }

    private final StreamHandleImpl handle;
    private final SampleListener listener;
    private final LinkedBlockingQueue<ReceivedSample> queue = new LinkedBlockingQueue<>();
    private final Semaphore room;
    private final AtomicLong received = new AtomicLong();
    private final AtomicLong dropped = new AtomicLong();
    private final Object state = new Object();
    private volatile DeliveryConnection conn;
    private volatile boolean ended;
    private volatile boolean closed;
    private volatile OpenAirException failure; // a refusal, or what ended the connection
    private Flow.Subscriber<? super ReceivedSample> subscriber;
    private final AtomicLong demand = new AtomicLong();

    StreamSubscriptionImpl(StreamHandleImpl handle, int buffer, SampleListener listener) {
        if (buffer < 1) {
            throw new ApiMisuseException("a subscription buffer holds at least 1 sample, not "
                    + buffer);
        }
        this.handle = handle;
        this.listener = listener;
        this.room = new Semaphore(buffer);
    }

    @Override
    public String target() {
        return handle.target();
    }

    @Override
    public long received() {
        return received.get();
    }

    @Override
    public long dropped() {
        return dropped.get();
    }

    @Override
    public boolean isActive() {
        return conn != null && !ended;
    }

    /** Open the push connection and wait until the stream counts it. */
    void open() {
        ModuleImpl module = handle.module();
        long before = handle.info().subscribers();
        Set<String> accepted = new TreeSet<>(module.extensions());
        // Without pipelining the server sends one sample at a time, so `buffer` bounds what waits.
        accepted.remove("pipelining");
        Session session = module.newStreamSession(accepted);
        Socket socket = Auth.connect(module.options(), module.options().host(),
                module.options().port());
        Auth.prove(module.options(), socket, module.newStreamSession(accepted)); // OA-AUTH-6
        DeliveryConnection d = new DeliveryConnection(socket, session, this::handleRequest,
                DeliveryPath.CALLBACK, module.options().clock(), this::onError,
                (reason, error) -> LOG.log(Level.DEBUG, "push sample dropped: " + reason),
                this::onEnd);
        Message.Builder note = Message.builder("RECEIVE_NAME_NOTIFICATION").sender(module.name())
                .to(handle.target());
        if (!module.legacy()) { // OA-SESS-19: declare what this connection accepts
            note.extra(Slot.text("extensions", String.join(" ", accepted)));
        }
        d.announce(note.build()); // OA-STREAM-8
        conn = d;
        d.start("openair-" + module.name() + "-push-" + handle.target());
        startDelivery();
        confirm(before);
    }

    private void confirm(long before) {
        long deadline = System.nanoTime() + handle.timeout().toNanos();
        long delay = FIRST_DELAY_MS;
        while (handle.info().subscribers() <= before) {
            synchronized (state) {
                if (failure != null) {
                    throw failure;
                }
                if (ended) {
                    throw new ConnectionClosedException("the server closed the push connection");
                }
                if (System.nanoTime() > deadline) {
                    throw new RequestTimeoutException("subscription to '" + handle.target()
                            + "' not confirmed");
                }
                try {
                    state.wait(delay);
                } catch (InterruptedException e) {
                    Thread.currentThread().interrupt();
                    throw new RequestTimeoutException("interrupted while subscribing");
                }
            }
            delay = Math.min(delay * 2, MAX_DELAY_MS);
        }
    }

    /** Buffer a pushed sample, then let it be acknowledged; refuse to answer a refusal. */
    private String handleRequest(Message msg, long receivedNanos, DeliveryPath path) {
        if (!msg.isresponse().isEmpty() || msg.type().equals("RECEIVE_ERROR")) {
            Message note = Message.builder("RECEIVE_NAME_NOTIFICATION")
                    .sender(handle.module().name()).to(handle.target()).build();
            synchronized (state) {
                failure = new RequestFailedException(note, msg); // e.g. STREAM_UNKNOWN
                state.notifyAll();
            }
            throw new Refused();
        }
        if (!msg.type().equals("DATASAMPLE")) {
            return null; // PING, KEEPALIVE: the default answers (OA-SESS-11)
        }
        ReceivedSample got = StreamWire.receivedOf(msg, receivedNanos); // else RECEIVE_ERROR
        received.incrementAndGet();
        dropped.addAndGet(got.dropped());
        try {
            room.acquire(); // a full buffer holds the acknowledgement back (OA-STREAM-8)
        } catch (InterruptedException e) {
            Thread.currentThread().interrupt();
            throw new ConnectionClosedException("interrupted");
        }
        queue.add(got);
        return null;
    }

    private void onError(Throwable error) {
        if (error instanceof Refused || closed) {
            return;
        }
        synchronized (state) {
            if (failure == null) {
                failure = error instanceof OpenAirException oa ? oa
                        : new ConnectionClosedException("push connection lost: " + error);
            }
        }
    }

    private void onEnd() {
        synchronized (state) {
            ended = true;
            state.notifyAll();
        }
        queue.add(END);
    }

    @Override
    public Optional<ReceivedSample> next(Duration timeout) {
        if (listener != null || subscriber != null) {
            throw new ApiMisuseException("this subscription hands its samples to a listener");
        }
        return Optional.ofNullable(take(timeout.toNanos()));
    }

    private ReceivedSample take(long nanos) {
        try {
            ReceivedSample s = queue.poll(nanos, TimeUnit.NANOSECONDS);
            if (s == END) {
                queue.add(END); // stays at the end for the next caller
                return null;
            }
            if (s != null) {
                room.release();
            }
            return s;
        } catch (InterruptedException e) {
            Thread.currentThread().interrupt();
            return null;
        }
    }

    @Override
    public void close() {
        synchronized (state) {
            if (closed) {
                return;
            }
            closed = true;
            state.notifyAll(); // a delivery thread waiting for demand ends
        }
        DeliveryConnection d = conn;
        if (d != null) {
            d.close();
        }
        room.release(1 << 20); // a reader blocked on a full buffer ends
        queue.add(END);
    }

    // ------------------------------------------------------------- listener and publisher

    private void startDelivery() {
        if (listener == null && subscriber == null) {
            return;
        }
        Thread t = new Thread(this::deliver, "openair-" + handle.module().name() + "-samples-"
                + handle.target());
        t.setDaemon(true);
        t.start();
    }

    private void deliver() {
        while (true) {
            if (subscriber != null && !awaitDemand()) {
                return;
            }
            ReceivedSample s = take(Long.MAX_VALUE);
            if (s == null) { // the end
                if (subscriber != null && !closed) {
                    OpenAirException f = failure;
                    if (f != null) {
                        subscriber.onError(f);
                    } else {
                        subscriber.onComplete();
                    }
                }
                return;
            }
            try {
                if (listener != null) {
                    listener.onSample(s);
                } else {
                    subscriber.onNext(s);
                }
            } catch (RuntimeException e) {
                LOG.log(Level.WARNING, "sample listener failed: " + e);
            }
        }
    }

    private boolean awaitDemand() {
        synchronized (state) {
            while (demand.get() == 0 && !closed) {
                try {
                    state.wait();
                } catch (InterruptedException e) {
                    return false;
                }
            }
            if (closed) {
                return false;
            }
            demand.decrementAndGet();
            return true;
        }
    }

    private void request(long n) {
        if (n <= 0) { // Reactive Streams rule 3.9
            close();
            subscriber.onError(new IllegalArgumentException("request(" + n + "): n must be > 0"));
            return;
        }
        synchronized (state) {
            long now = demand.get();
            demand.set(now + n < 0 ? Long.MAX_VALUE : now + n);
            state.notifyAll();
        }
    }

    private void cancel() {
        close();
        synchronized (state) {
            state.notifyAll();
        }
    }

    /** Give {@code subscriber} a push subscription of its own (see StreamHandle#publisher). */
    static void publish(StreamHandleImpl handle, Flow.Subscriber<? super ReceivedSample> sub) {
        StreamSubscriptionImpl s = new StreamSubscriptionImpl(handle, 100, null);
        s.subscriber = sub;
        sub.onSubscribe(new Flow.Subscription() {
            @Override
            public void request(long n) {
                s.request(n);
            }

            @Override
            public void cancel() {
                s.cancel();
            }
        });
        try {
            handle.registerForPublisher(s);
        } catch (RuntimeException e) {
            sub.onError(e);
        }
    }

}

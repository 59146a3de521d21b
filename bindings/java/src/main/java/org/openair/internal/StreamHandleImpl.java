package org.openair.internal;

import java.lang.System.Logger.Level;
import java.time.Duration;
import java.util.ArrayDeque;
import java.util.ArrayList;
import java.util.Deque;
import java.util.HashSet;
import java.util.List;
import java.util.Map;
import java.util.Optional;
import java.util.Set;
import java.util.concurrent.CompletableFuture;
import java.util.concurrent.CompletionException;
import java.util.concurrent.Flow;
import java.util.concurrent.TimeUnit;
import java.util.concurrent.TimeoutException;
import org.openair.ApiMisuseException;
import org.openair.ConnectionClosedException;
import org.openair.DataSample;
import org.openair.ErrorCode;
import org.openair.Message;
import org.openair.OpenAirException;
import org.openair.ReceivedSample;
import org.openair.RequestFailedException;
import org.openair.RequestTimeoutException;
import org.openair.SampleListener;
import org.openair.StreamHandle;
import org.openair.StreamInfo;
import org.openair.StreamLock;
import org.openair.StreamSubscription;

/**
 * {@link StreamHandle} over the module's stream connections: one main connection (opened with
 * GET_NAME, so that the stream is its current stream, OA-STREAM-11) and a pool of connections for
 * waiting commands, which block theirs (OA-SESS-2).
 *
 * <p>Threading: thread-safe; {@code lock} guards the connections, the links guard themselves.
 */
final class StreamHandleImpl implements StreamHandle {
    private static final System.Logger LOG = System.getLogger("org.openair");
    static final String TYPED_STREAMS = "typed-streams";

    private final ModuleImpl module;
    private final String target;
    private final Object lock = new Object();
    private Link link; // guarded by lock
    private String streamName = ""; // guarded by lock
    private final Deque<Link> idleWaits = new ArrayDeque<>(); // guarded by lock
    private final Set<Link> busyWaits = new HashSet<>(); // guarded by lock
    private final List<StreamSubscriptionImpl> subscriptions = new ArrayList<>(); // guarded
    private boolean closed; // guarded by lock

    StreamHandleImpl(ModuleImpl module, String target) {
        if (target == null || target.isEmpty()) {
            throw new ApiMisuseException("a stream handle needs a stream name or type");
        }
        this.module = module;
        this.target = target;
    }

    ModuleImpl module() {
        return module;
    }

    Duration timeout() {
        return module.options().requestTimeout();
    }

    @Override
    public String target() {
        return target;
    }

    @Override
    public String toString() {
        return "StreamHandle[" + target + "]";
    }

    // ------------------------------------------------------------------------- connections

    private Link main() {
        synchronized (lock) {
            if (closed) {
                throw new ConnectionClosedException("the stream handle is closed");
            }
            if (link == null || link.isClosed()) {
                Link l = module.openStreamLink("stream");
                try { // any media command makes the stream this connection's current stream
                    Message[] r = l.request(request("GET_NAME", "", false), timeout());
                    expect(r, "NAME");
                    streamName = Dom.strip(r[1].content());
                } catch (RuntimeException e) {
                    l.close();
                    throw e;
                }
                link = l;
            }
            return link;
        }
    }

    private Message request(String type, String content, boolean xml) {
        return StreamWire.request(target, module.name(), type, content, xml);
    }

    static Message expect(Message[] sentAndReply, String type) {
        if (!sentAndReply[1].type().equals(type)) {
            throw new RequestFailedException(sentAndReply[0], sentAndReply[1]);
        }
        return sentAndReply[1];
    }

    private Message ask(String type, String content, boolean xml, String expected) {
        return expect(main().request(request(type, content, xml), timeout()), expected);
    }

    void requireTyped(String command) {
        boolean offered = module.capabilities()
                .map(c -> c.extensions().contains(TYPED_STREAMS)).orElse(false);
        if (!offered) { // OA-GEN-2
            throw new ApiMisuseException(command + " needs a server that advertises "
                    + TYPED_STREAMS);
        }
    }

    @Override
    public String name() {
        main();
        synchronized (lock) {
            return streamName;
        }
    }

    @Override
    public void close() {
        List<Link> links = new ArrayList<>();
        List<StreamSubscriptionImpl> subs;
        synchronized (lock) {
            closed = true;
            if (link != null) {
                links.add(link);
            }
            links.addAll(idleWaits);
            links.addAll(busyWaits);
            link = null;
            idleWaits.clear();
            subs = new ArrayList<>(subscriptions);
            subscriptions.clear();
        }
        for (StreamSubscriptionImpl s : subs) {
            s.close();
        }
        for (Link l : links) {
            l.close();
        }
    }

    // ------------------------------------------------------------------------- writing

    private Link.Sent write(DataSample sample) {
        Message msg = request("ADD_SAMPLE", StreamWire.DATASAMPLE_XML, true);
        return main().submitParts(msg, List.of(SampleCodec.parts(sample)), timeout());
    }

    private long idOf(Link l, Link.Sent sent) {
        Message reply = l.await(sent, timeout());
        return StreamWire.integerOf(expect(new Message[] {sent.message(), reply},
                "DATA_ACCEPTED"), "sample id");
    }

    @Override
    public long add(DataSample sample) {
        Link l = main();
        return idOf(l, write(sample));
    }

    @Override
    public List<Long> addAll(List<DataSample> samples) {
        List<SampleCodec.Parts> chunks = new ArrayList<>(samples.size());
        for (DataSample s : samples) {
            chunks.add(SampleCodec.parts(s));
        }
        Message msg = request("ADD_SAMPLES", StreamWire.addSamplesContent(samples.size()), true);
        Link l = main();
        Link.Sent sent = l.submitParts(msg, chunks, timeout());
        Message reply = l.await(sent, timeout());
        return StreamWire.idsOf(expect(new Message[] {sent.message(), reply}, "DATA_ACCEPTED"));
    }

    @Override
    public CompletableFuture<Long> submit(DataSample sample, boolean binary) {
        Link l = main();
        Link.Sent sent = binary ? l.submitBinary(SampleCodec.parts(sample), timeout())
                : write(sample);
        // handleAsync: the caller's continuations never run on the connection's reader thread.
        return sent.reply().orTimeout(timeout().toNanos(), TimeUnit.NANOSECONDS)
                .handleAsync((reply, error) -> {
                    if (error instanceof TimeoutException) {
                        l.abort(); // OA-SESS-27
                        throw new RequestTimeoutException(sent.message().type()
                                + ": no reply in time");
                    }
                    if (error != null) {
                        throw error instanceof OpenAirException oa ? oa
                                : new CompletionException(error);
                    }
                    return StreamWire.integerOf(expect(new Message[] {sent.message(), reply},
                            "DATA_ACCEPTED"), "sample id");
                });
    }

    @Override
    public List<Long> addPipelined(List<DataSample> samples) {
        Link l = main();
        List<Link.Sent> pending = new ArrayList<>(samples.size());
        for (DataSample s : samples) { // up to the window in flight (OA-SESS-17)
            pending.add(write(s));
        }
        List<Long> ids = new ArrayList<>(samples.size());
        OpenAirException failure = null;
        for (Link.Sent s : pending) {
            try {
                ids.add(idOf(l, s));
            } catch (OpenAirException e) {
                failure = failure == null ? e : failure;
            }
        }
        if (failure != null) {
            throw failure;
        }
        return ids;
    }

    @Override
    public void addNoReply(DataSample sample) {
        Link l = main();
        List<SampleCodec.Parts> chunk = List.of(SampleCodec.parts(sample));
        Message msg = request("ADD_SAMPLE", StreamWire.DATASAMPLE_XML, true);
        if (module.extensions().contains("noreply")) { // OA-MSG-15: no reply comes
            l.submitParts(msg.toBuilder().noreply(true).build(), chunk, timeout());
            return;
        }
        Link.Sent s = l.submitParts(msg, chunk, timeout()); // OA-GEN-2: an ordinary add
        s.reply().whenComplete((reply, error) -> {
            if (error != null || !reply.type().equals("DATA_ACCEPTED")) {
                LOG.log(Level.WARNING, "unacknowledged sample write failed: "
                        + (error != null ? error : reply.type() + " " + reply.content()));
            }
        });
    }

    // ------------------------------------------------------------------------- reading

    private DataSample sample(String type, String content, boolean xml) {
        return StreamWire.sampleOf(ask(type, content, xml, "DATASAMPLE"));
    }

    @Override
    public DataSample get(long id) {
        return sample("GET_SAMPLE_BY_ID", Long.toString(id), false);
    }

    @Override
    public DataSample at(long ms) {
        return sample("GET_SAMPLE_BY_TIME", StreamWire.timeContent(ms), true);
    }

    @Override
    public List<DataSample> between(long fromMs, long untilMs) {
        return StreamWire.samplesOf(ask("GET_SAMPLES_BY_TIME",
                StreamWire.rangeContent(fromMs, untilMs), true, "DATASAMPLES"));
    }

    @Override
    public DataSample newest() {
        return sample("GET_NEWEST_DATASAMPLE", "", false);
    }

    @Override
    public DataSample oldest() {
        return sample("GET_OLDEST_DATASAMPLE", "", false);
    }

    @Override
    public long newestTimestamp() {
        return StreamWire.timestampOf(ask("GET_NEWEST_TIMESTAMP", "", false, "TIMESTAMP"));
    }

    @Override
    public long oldestTimestamp() {
        return StreamWire.timestampOf(ask("GET_OLDEST_TIMESTAMP", "", false, "TIMESTAMP"));
    }

    @Override
    public long count() {
        return StreamWire.integerOf(ask("GET_COUNT", "", false, "COUNT"), "count");
    }

    @Override
    public long size() {
        return StreamWire.integerOf(ask("GET_SIZE", "", false, "SIZE"), "size");
    }

    @Override
    public StreamInfo info() {
        return StreamWire.infoOf(ask("GET_INFO", "", false, "INFO"));
    }

    @Override
    public List<DataSample> search(Long afterMs, Long untilMs, Map<String, String> params,
            int latest) {
        requireTyped("SEARCH_SAMPLES");
        String content = StreamWire.searchContent(afterMs, untilMs,
                params == null ? Map.of() : params, latest);
        return StreamWire.samplesOf(ask("SEARCH_SAMPLES", content, true, "DATASAMPLES"));
    }

    // ------------------------------------------------------------------------- waiting

    @Override
    public Optional<DataSample> waitAfterId(long id, Duration timeout, boolean last) {
        String type = StreamWire.waitType(true, last, timeout.toMillis());
        return await(request(type, Long.toString(id), false), timeout);
    }

    @Override
    public Optional<DataSample> waitForSample(long ms, Duration timeout, boolean last) {
        String type = StreamWire.waitType(false, last, timeout.toMillis());
        return await(request(type, StreamWire.timeContent(ms), true), timeout);
    }

    /** Run a waiting command on a pooled connection of its own (it blocks it, OA-SESS-2). */
    private Optional<DataSample> await(Message msg, Duration wait) {
        Link l = waitLink();
        Message[] r;
        try {
            r = l.request(msg, timeout().plus(wait));
        } catch (RuntimeException e) {
            l.close(); // a wait still pending on the server would hold up the next one
            synchronized (lock) {
                busyWaits.remove(l);
            }
            throw e;
        }
        synchronized (lock) {
            busyWaits.remove(l);
            if (closed) {
                l.close();
            } else {
                idleWaits.addLast(l);
            }
        }
        if (r[1].type().equals("DATASAMPLE")) {
            return Optional.of(StreamWire.sampleOf(r[1]));
        }
        RequestFailedException failed = new RequestFailedException(r[0], r[1]);
        if (failed.condition().orElse(null) == ErrorCode.SAMPLE_UNKNOWN) {
            return Optional.empty(); // OA-STREAM-7: the timeout passed first
        }
        throw failed;
    }

    private Link waitLink() {
        synchronized (lock) {
            if (closed) {
                throw new ConnectionClosedException("the stream handle is closed");
            }
            while (!idleWaits.isEmpty()) {
                Link l = idleWaits.pollLast();
                if (!l.isClosed()) {
                    busyWaits.add(l);
                    return l;
                }
            }
        }
        Link l = module.openStreamLink("wait");
        synchronized (lock) {
            if (closed) {
                l.close();
                throw new ConnectionClosedException("the stream handle is closed");
            }
            busyWaits.add(l);
        }
        return l;
    }

    // ------------------------------------------------------------------------- locks

    @Override
    public StreamLock lock(long first, long last) {
        requireTyped("LOCK_SAMPLES");
        String content = StreamWire.lockContent(first, last);
        Link l = main();
        Message msg = request("LOCK_SAMPLES", content, false);
        long id = StreamWire.integerOf(expect(l.request(msg, timeout()), "LOCKED"), "lock id");
        return new Lock(l, id, first, last);
    }

    @Override
    public void unlock(long lockId) {
        requireTyped("UNLOCK_SAMPLES");
        ask("UNLOCK_SAMPLES", Long.toString(lockId), false, "RECEIVE_ACCEPT");
    }

    /** A lock held by the connection that took it. */
    private final class Lock implements StreamLock {
        private final Link owner;
        private final long id;
        private final long first;
        private final long last;
        private boolean released; // guarded by this

        Lock(Link owner, long id, long first, long last) {
            this.owner = owner;
            this.id = id;
            this.first = first;
            this.last = last;
        }

        @Override
        public long lockId() {
            return id;
        }

        @Override
        public long first() {
            return first;
        }

        @Override
        public long last() {
            return last;
        }

        @Override
        public synchronized void close() {
            if (released) {
                return;
            }
            synchronized (lock) {
                if (owner != link || owner.isClosed()) {
                    released = true; // OA-XSTREAM-5: released with its connection
                    throw new ConnectionClosedException("the lock was released with its"
                            + " connection");
                }
            }
            Message msg = request("UNLOCK_SAMPLES", Long.toString(id), false);
            expect(owner.request(msg, timeout()), "RECEIVE_ACCEPT");
            released = true;
        }

        @Override
        public String toString() {
            return "StreamLock[" + id + ": " + first + "-" + last + "]";
        }
    }

    // ------------------------------------------------------------------------- push

    private StreamSubscriptionImpl register(StreamSubscriptionImpl s) {
        synchronized (lock) {
            if (closed) {
                throw new ConnectionClosedException("the stream handle is closed");
            }
            subscriptions.add(s);
        }
        try {
            s.open();
        } catch (RuntimeException e) {
            s.close();
            synchronized (lock) {
                subscriptions.remove(s);
            }
            throw e;
        }
        return s;
    }

    @Override
    public StreamSubscription subscribe(int buffer) {
        return register(new StreamSubscriptionImpl(this, buffer, null));
    }

    @Override
    public StreamSubscription subscribe(SampleListener listener) {
        if (listener == null) {
            throw new ApiMisuseException("a listener is needed");
        }
        return register(new StreamSubscriptionImpl(this, 100, listener));
    }

    @Override
    public Flow.Publisher<ReceivedSample> publisher() {
        return subscriber -> StreamSubscriptionImpl.publish(this, subscriber);
    }

    StreamSubscriptionImpl registerForPublisher(StreamSubscriptionImpl s) {
        return register(s);
    }
}

package org.openair.internal;

import java.io.IOException;
import java.io.InputStream;
import java.io.OutputStream;
import java.net.InetAddress;
import java.net.InetSocketAddress;
import java.net.Socket;
import java.net.SocketTimeoutException;
import java.time.Duration;
import java.util.ArrayDeque;
import java.util.ArrayList;
import java.util.Deque;
import java.util.List;
import java.util.Set;
import java.util.concurrent.CompletableFuture;
import java.util.concurrent.ExecutionException;
import java.util.concurrent.TimeUnit;
import java.util.concurrent.TimeoutException;
import org.openair.ConnectionClosedException;
import org.openair.ErrorCode;
import org.openair.Message;
import org.openair.OpenAirException;
import org.openair.RemoteProtocolException;
import org.openair.RequestTimeoutException;

/**
 * The requester side of one connection over a blocking socket (spec 6.1): sends requests within
 * the window (OA-SESS-17/18), pairs each reply with the oldest waiting request (OA-SESS-33) and,
 * when a reply does not come in time, closes the connection (OA-SESS-27) so that its owner can
 * reconnect.
 *
 * <p>Threading: thread-safe. One reader thread per link completes the reply futures; any thread
 * may send. Writers take {@code writeLock} first, so the order of the futures is the order of the
 * frames on the wire; the session is guarded by {@code state}, which the reader also takes.
 */
final class Link {
    /** Told when the link ends without {@link #close()} having been called. */
    interface LostHandler {
        void lost(Link link, OpenAirException cause);
    }

    /**
     * A request as sent, with the future of its reply.
     *
     * @param message the request, with its postedTime
     * @param reply completes with the reply, or fails with CONNECTION_CLOSED
     */
    record Sent(Message message, CompletableFuture<Message> reply) {}

    /** OA-FRAME-12: a frame whose bytes stop arriving for this long is FRAME_TRUNCATED. */
    static final int FRAME_DEADLINE_MS = 30_000;

    private final Socket socket;
    private final InputStream in;
    private final OutputStream out;
    private final Session session;
    private final LostHandler onLost;
    private final Object state = new Object();
    private final Object writeLock = new Object();
    private final Deque<CompletableFuture<Message>> waiting = new ArrayDeque<>();
    private final Thread reader;
    private boolean closed; // guarded by state
    private volatile boolean closing;
    private volatile long lastTraffic = System.nanoTime();

    private Link(Socket socket, Session session, LostHandler onLost, String threadName)
            throws IOException {
        this.socket = socket;
        this.in = socket.getInputStream();
        this.out = socket.getOutputStream();
        this.session = session;
        this.onLost = onLost;
        this.reader = new Thread(this::readLoop, threadName);
        reader.setDaemon(true);
    }

    /**
     * Open a TCP connection and start reading replies.
     *
     * @param host the server host
     * @param port its port
     * @param connectTimeout the TCP connect timeout
     * @param session the session (REQUESTER role)
     * @param threadName the reader thread's name
     * @param onLost told when the link ends unexpectedly
     * @return the link
     * @throws ConnectionClosedException when the connection cannot be made
     */
    static Link open(String host, int port, Duration connectTimeout, Session session,
            String threadName, LostHandler onLost) {
        return open(connect(host, port, connectTimeout), session, threadName, onLost);
    }

    /**
     * Wrap a connection already open (plain or TLS, spec 14.3) and start reading replies.
     *
     * @param socket the connection
     * @param session the session (REQUESTER role)
     * @param threadName the reader thread's name
     * @param onLost told when the link ends unexpectedly
     * @return the link
     * @throws ConnectionClosedException when the connection cannot be used
     */
    static Link open(Socket socket, Session session, String threadName, LostHandler onLost) {
        try {
            Link link = new Link(socket, session, onLost, threadName);
            link.reader.start();
            return link;
        } catch (IOException e) {
            closeQuietly(socket);
            throw new ConnectionClosedException("cannot use the connection: " + e.getMessage());
        }
    }

    static Socket connect(String host, int port, Duration timeout) {
        Socket socket = new Socket();
        try {
            socket.setTcpNoDelay(true);
            socket.connect(new InetSocketAddress(host, port), (int) Math.min(
                    Integer.MAX_VALUE, timeout.toMillis()));
            return socket;
        } catch (IOException e) {
            closeQuietly(socket);
            throw new ConnectionClosedException("cannot connect to " + host + ":" + port + ": "
                    + e.getMessage());
        }
    }

    static void closeQuietly(Socket s) {
        try {
            s.close();
        } catch (IOException e) {
            // nothing left to do
        }
    }

    /** @return the local address of this connection (the interface that reaches the server) */
    InetAddress localAddress() {
        return socket.getLocalAddress();
    }

    /** @return System.nanoTime() of the last byte sent or received */
    long lastTraffic() {
        return lastTraffic;
    }

    /** @return whether the link has ended */
    boolean isClosed() {
        synchronized (state) {
            return closed;
        }
    }

    /**
     * Set the window and the extensions in use (after capabilities are known).
     *
     * @param window requests that may be in flight
     * @param extensions extensions in use
     */
    void configure(int window, Set<String> extensions) {
        synchronized (state) {
            session.window(window);
            session.extensions(extensions);
            state.notifyAll();
        }
    }

    /**
     * Send request {@code msg} once the window allows.
     *
     * @param msg the request
     * @param timeout how long to wait for a free slot
     * @return the request as sent and its reply future
     */
    Sent submit(Message msg, Duration timeout) {
        long deadline = System.nanoTime() + timeout.toNanos();
        synchronized (writeLock) {
            byte[] data;
            Sent sent;
            synchronized (state) {
                awaitSlot(msg, deadline);
                data = session.sendRequest(msg);
                sent = new Sent(session.lastSent(), new CompletableFuture<>());
                waiting.addLast(sent.reply());
            }
            write(data);
            return sent;
        }
    }

    private void awaitSlot(Message msg, long deadline) {
        while (true) {
            if (closed) {
                throw new ConnectionClosedException("the connection to the server is closed");
            }
            if (session.canSend()) {
                return;
            }
            long left = deadline - System.nanoTime();
            if (left <= 0) {
                // The window stayed full for a whole timeout: the oldest request has gone
                // unanswered that long, so the connection is closed as OA-SESS-27 advises.
                abort();
                throw new RequestTimeoutException(msg.type() + ": no request slot in time");
            }
            try {
                TimeUnit.NANOSECONDS.timedWait(state, left);
            } catch (InterruptedException e) {
                Thread.currentThread().interrupt();
                throw new RequestTimeoutException("interrupted while waiting for a request slot");
            }
        }
    }

    /**
     * Send a {@code noreply} message: no acknowledgement follows (OA-MSG-15).
     *
     * @param msg the message, with noreply set
     * @return the message as sent
     */
    Message sendNoReply(Message msg) {
        synchronized (writeLock) {
            byte[] data;
            Message sent;
            synchronized (state) {
                if (closed) {
                    throw new ConnectionClosedException("the connection to the server is closed");
                }
                data = session.sendRequest(msg);
                sent = session.lastSent();
            }
            write(data);
            return sent;
        }
    }

    /**
     * Send a request whose binary chunks are sample parts, written from their own buffers
     * (OA-FRAME-4); with {@code msg.noreply()} no reply is awaited (OA-MSG-15) and the returned
     * future is null.
     *
     * @param msg the request, without chunks of its own
     * @param chunks the chunks
     * @param timeout how long to wait for a free slot
     * @return the request as sent and its reply future (null under noreply)
     */
    Sent submitParts(Message msg, List<SampleCodec.Parts> chunks, Duration timeout) {
        long[] sizes = new long[chunks.size()];
        for (int i = 0; i < sizes.length; i++) {
            sizes[i] = chunks.get(i).size();
        }
        long deadline = System.nanoTime() + timeout.toNanos();
        synchronized (writeLock) {
            byte[] head;
            Sent sent;
            synchronized (state) {
                if (!msg.noreply()) {
                    awaitSlot(msg, deadline);
                } else if (closed) {
                    throw new ConnectionClosedException("the connection to the server is closed");
                }
                head = session.sendRequestHead(msg, sizes);
                sent = new Sent(session.lastSent(), msg.noreply() ? null : new CompletableFuture<>());
                if (sent.reply() != null) {
                    waiting.addLast(sent.reply());
                }
            }
            writeParts(head, chunks);
            return sent;
        }
    }

    /**
     * Send one sample as a bare {@code BinaryM} frame (OA-STREAM-11); the stream answers it.
     *
     * @param chunk the sample's chunk
     * @param timeout how long to wait for a free slot
     * @return the frame (as a message named BinaryM) and its reply future
     */
    Sent submitBinary(SampleCodec.Parts chunk, Duration timeout) {
        long deadline = System.nanoTime() + timeout.toNanos();
        Message what = Message.builder("BinaryM").id("").build();
        synchronized (writeLock) {
            byte[] head;
            Sent sent;
            synchronized (state) {
                awaitSlot(what, deadline);
                head = session.sendBinaryHead(chunk.size());
                sent = new Sent(what, new CompletableFuture<>());
                waiting.addLast(sent.reply());
            }
            writeParts(head, List.of(chunk));
            return sent;
        }
    }

    /* Small frames go as one array (one write, one packet); big payloads from their buffers. */
    private void writeParts(byte[] head, List<SampleCodec.Parts> chunks) {
        long total = head.length;
        for (SampleCodec.Parts p : chunks) {
            total += p.size();
        }
        if (total < SampleCodec.JOIN_BELOW) {
            byte[] all = new byte[(int) total];
            System.arraycopy(head, 0, all, 0, head.length);
            int at = head.length;
            for (SampleCodec.Parts p : chunks) {
                byte[] c = p.join();
                System.arraycopy(c, 0, all, at, c.length);
                at += c.length;
            }
            write(all);
            return;
        }
        try {
            out.write(head);
            for (SampleCodec.Parts p : chunks) {
                out.write(p.length());
                p.payload().writePayload(out); // from the caller's buffer
                out.write(p.tail());
            }
            out.flush();
            lastTraffic = System.nanoTime();
        } catch (IOException e) {
            abort();
            throw new ConnectionClosedException("write failed: " + e.getMessage());
        }
    }

    private void write(byte[] data) {
        try {
            out.write(data);
            out.flush();
            lastTraffic = System.nanoTime();
        } catch (IOException e) {
            abort();
            throw new ConnectionClosedException("write failed: " + e.getMessage());
        }
    }

    /**
     * Wait for a reply; on timeout close the connection (OA-SESS-27).
     *
     * @param sent the request and its future
     * @param timeout how long to wait
     * @return the reply
     */
    Message await(Sent sent, Duration timeout) {
        try {
            return sent.reply().get(timeout.toNanos(), TimeUnit.NANOSECONDS);
        } catch (TimeoutException e) {
            abort(); // a late reply could no longer be paired
            throw new RequestTimeoutException(sent.message().type() + ": no reply within "
                    + timeout.toMillis() + " ms");
        } catch (ExecutionException e) {
            Throwable cause = e.getCause();
            if (cause instanceof OpenAirException oa) {
                throw oa;
            }
            throw new ConnectionClosedException(String.valueOf(cause));
        } catch (InterruptedException e) {
            Thread.currentThread().interrupt();
            throw new RequestTimeoutException("interrupted while waiting for the reply");
        }
    }

    /**
     * Send {@code msg} and wait for its reply.
     *
     * @param msg the request
     * @param timeout the reply timeout (also bounds the wait for a slot)
     * @return the request as sent, then the reply
     */
    Message[] request(Message msg, Duration timeout) {
        Sent sent = submit(msg, timeout);
        return new Message[] {sent.message(), await(sent, timeout)};
    }

    private void readLoop() {
        OpenAirException error = null;
        byte[] buf = new byte[65536];
        try {
            while (true) {
                int n = read(buf);
                List<Session.Event> events;
                synchronized (state) {
                    events = n < 0 ? session.receiveEof() : session.receive(buf, 0, n);
                }
                for (Session.Event event : events) {
                    if (event instanceof Session.Reply reply) {
                        resolve(reply.message());
                    } else if (event instanceof Session.Closed) {
                        return;
                    }
                }
            }
        } catch (RemoteProtocolException e) {
            error = e;
        } catch (IOException e) {
            error = new ConnectionClosedException("connection lost: " + e.getMessage());
        } catch (OpenAirException e) {
            error = e;
        } catch (RuntimeException e) { // a defect must not leave requests waiting forever
            error = new ConnectionClosedException("reading replies failed: " + e);
        } finally {
            shutdown(error);
        }
    }

    /** Read, treating a frame whose bytes stop coming as FRAME_TRUNCATED (OA-FRAME-12). */
    private int read(byte[] buf) throws IOException {
        boolean inFrame;
        synchronized (state) {
            inFrame = session.inFrame();
        }
        socket.setSoTimeout(inFrame ? FRAME_DEADLINE_MS : 0);
        try {
            int n = in.read(buf);
            lastTraffic = System.nanoTime();
            return n;
        } catch (SocketTimeoutException e) {
            throw new RemoteProtocolException(ErrorCode.FRAME_TRUNCATED,
                    "no byte of the frame for " + FRAME_DEADLINE_MS + " ms");
        }
    }

    private void resolve(Message reply) {
        CompletableFuture<Message> f;
        synchronized (state) {
            f = waiting.pollFirst();
            state.notifyAll(); // a slot is free
        }
        if (f != null) {
            f.complete(reply);
        }
    }

    private void shutdown(OpenAirException error) {
        List<CompletableFuture<Message>> failed;
        synchronized (state) {
            if (closed) {
                return;
            }
            closed = true;
            failed = new ArrayList<>(waiting);
            waiting.clear();
            state.notifyAll();
        }
        closeQuietly(socket);
        if (!closing) {
            onLost.lost(this, error); // first, so that a failed caller finds the module told
        }
        String reason = error == null ? "connection closed by the server"
                : "connection lost: " + error.getMessage();
        for (CompletableFuture<Message> f : failed) {
            f.completeExceptionally(new ConnectionClosedException(reason));
        }
    }

    /** Close the connection as if it were lost: the owner is told and may reconnect. */
    void abort() {
        closeQuietly(socket);
    }

    /** Close the connection on purpose; waiting requests fail with CONNECTION_CLOSED. */
    void close() {
        closing = true;
        closeQuietly(socket);
        if (Thread.currentThread() != reader) {
            try {
                reader.join(2000);
            } catch (InterruptedException e) {
                Thread.currentThread().interrupt();
            }
        }
        shutdown(null);
    }
}

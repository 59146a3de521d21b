package org.openair.internal;

import java.io.IOException;
import java.io.InputStream;
import java.io.OutputStream;
import java.net.Socket;
import java.net.SocketTimeoutException;
import java.util.List;
import java.util.function.BiConsumer;
import java.util.function.Consumer;
import java.util.function.LongSupplier;
import org.openair.ConnectionClosedException;
import org.openair.DeliveryPath;
import org.openair.ErrorCode;
import org.openair.Message;
import org.openair.OpenAirException;
import org.openair.RemoteProtocolException;

/**
 * One connection on which the server is the requester (spec 6.5, 6.6): a connection it opened to
 * the module's listening port, or the module's callback connection after its {@code Receive}
 * frame. Each request is handed to the {@link Handler} with its arrival time and answered in
 * arrival order (OA-SESS-2, OA-SESS-11, OA-DELIV-4). A remote protocol error closes this
 * connection only (OA-ERR-4).
 *
 * <p>Threading: one reader thread per connection reads, calls the handler and writes the answers;
 * {@link #close()} may be called from any thread.
 */
final class DeliveryConnection implements Runnable {
    /** Handles one delivered request; returns the reply type, or null for the default answer. */
    interface Handler {
        /**
         * Handle a request.
         *
         * @param msg the request
         * @param receivedNanos when its bytes arrived (read before parsing)
         * @param path the connection that carried it
         * @return the reply type, or null
         * @throws OpenAirException to answer RECEIVE_ERROR with {@code NAME: detail} (OA-ERR-2)
         */
        String handle(Message msg, long receivedNanos, DeliveryPath path);
    }

    private final Socket socket;
    private final Session session;
    private final Handler handler;
    private final DeliveryPath path;
    private final LongSupplier clock;
    private final Consumer<Throwable> onError;
    private final BiConsumer<String, OpenAirException> onDropped;
    private final Runnable onEnd;
    private volatile boolean closing;

    DeliveryConnection(Socket socket, Session session, Handler handler, DeliveryPath path,
            LongSupplier clock, Consumer<Throwable> onError,
            BiConsumer<String, OpenAirException> onDropped,
            Runnable onEnd) {
        this.socket = socket;
        this.session = session;
        this.handler = handler;
        this.path = path;
        this.clock = clock;
        this.onError = onError;
        this.onDropped = onDropped;
        this.onEnd = onEnd;
    }

    /**
     * Send the {@code Receive} frame that makes this the callback connection (OA-SESS-7).
     *
     * @param notification the RECEIVE_NAME_NOTIFICATION
     */
    void announce(Message notification) {
        try {
            OutputStream out = socket.getOutputStream();
            out.write(session.sendNotification(notification));
            out.flush();
        } catch (IOException e) {
            close();
            throw new ConnectionClosedException("cannot open the callback connection: "
                    + e.getMessage());
        }
    }

    /**
     * Start the reader thread.
     *
     * @param name the thread's name
     */
    void start(String name) {
        Thread t = new Thread(this, name);
        t.setDaemon(true);
        t.start();
    }

    @Override
    public void run() {
        byte[] buf = new byte[65536];
        try {
            InputStream in = socket.getInputStream();
            OutputStream out = socket.getOutputStream();
            while (true) {
                socket.setSoTimeout(session.inFrame() ? Link.FRAME_DEADLINE_MS : 0);
                int n;
                try {
                    n = in.read(buf);
                } catch (SocketTimeoutException e) { // OA-FRAME-12
                    throw new RemoteProtocolException(ErrorCode.FRAME_TRUNCATED,
                            "no byte of the frame for " + Link.FRAME_DEADLINE_MS + " ms");
                }
                long receivedNanos = clock.getAsLong(); // the first act on arrival
                List<Session.Event> events = n < 0 ? session.receiveEof()
                        : session.receive(buf, 0, n);
                for (Session.Event event : events) {
                    if (event instanceof Session.Closed) {
                        return;
                    }
                    byte[] answer = answer(event, receivedNanos);
                    if (answer != null) {
                        out.write(answer);
                    }
                }
                out.flush();
            }
        } catch (RemoteProtocolException e) {
            // OA-MSG-20; the error itself is reported through onError below.
            onDropped.accept("delivery connection closed: " + e.wireText(), null);
            answerFramingError(e); // OA-FRAME-7: a responder says why before it closes
            if (!closing) {
                onError.accept(e);
            }
        } catch (IOException | OpenAirException e) {
            if (!closing) {
                onError.accept(e);
            }
        } catch (RuntimeException e) {
            onError.accept(e); // a defect must not go unnoticed
        } finally {
            Link.closeQuietly(socket);
            onEnd.run();
        }
    }

    private void answerFramingError(RemoteProtocolException e) {
        byte[] reply = session.framingErrorReply(e);
        if (reply == null) {
            return;
        }
        try {
            OutputStream out = socket.getOutputStream();
            out.write(reply);
            out.flush();
        } catch (IOException ignored) {
            // the connection is being closed anyway
        }
    }

    private byte[] answer(Session.Event event, long receivedNanos) {
        if (event instanceof Session.Invalid invalid) {
            onDropped.accept(invalid.error().wireText(), invalid.error()); // OA-MSG-20
            return session.answer(event, null, ""); // OA-ERR-3: RECEIVE_ERROR, stays usable
        }
        if (!(event instanceof Session.Request request)) {
            return null; // a responder never pairs replies (OA-SESS-28)
        }
        String type;
        try {
            type = handler.handle(request.message(), receivedNanos, path);
        } catch (OpenAirException e) {
            Message m = request.message();
            onDropped.accept("'" + m.type() + "' " + m.id() + ": " + e.wireText(), e); // OA-MSG-20
            if (!request.needsAnswer()) {
                return null;
            }
            return session.answer(event, "RECEIVE_ERROR", e.wireText()); // OA-SESS-11, OA-ERR-2
        }
        if (!request.needsAnswer()) {
            return null; // OA-MSG-15: a noreply delivery is never acknowledged
        }
        return session.answer(event, type, "");
    }

    /** Close the connection; the reader thread ends. */
    void close() {
        closing = true;
        Link.closeQuietly(socket);
    }
}

package org.openair.example;

import org.openair.Message;
import org.openair.Module;
import org.openair.OpenAir;
import org.openair.OpenAirException;
import org.openair.Options;

/**
 * Consumer: post one message through the installed client library and print what was sent.
 *
 * <p>Run: {@code java -cp target/classes:openair.jar org.openair.example.Consumer HOST PORT
 * [CONTENT]}; prints {@code openair VERSION} and {@code posted TYPE to WB ID}. Exit status 0 when
 * the server acknowledged the post, 2 on bad arguments, 1 on an OpenAIR failure.
 */
public final class Consumer {
    private Consumer() {}

    public static void main(String[] args) {
        if (args.length < 2 || args.length > 3) {
            System.err.println("usage: Consumer HOST PORT [CONTENT]");
            System.exit(2);
        }
        int port;
        try {
            port = Integer.parseInt(args[1]);
        } catch (NumberFormatException e) {
            System.err.println("Consumer: PORT is not a number: " + args[1]);
            System.exit(2);
            return;
        }
        String content = args.length > 2 ? args[2] : "hello from the consumer";
        System.out.println("openair " + OpenAir.VERSION);
        // A plain client: no BIND, so no listening port and no callback connection.
        Options options = Options.builder("Consumer").server(args[0], port).bind(false).build();
        try (Module module = OpenAir.connect(options)) {
            Message sent = module.post("WB1", "Example.Consumer.Hello", content);
            System.out.println("posted " + sent.type() + " to " + sent.to() + " " + sent.id());
        } catch (OpenAirException e) {
            System.err.println("Consumer: " + e.getMessage());
            System.exit(1);
        }
    }
}

#!/usr/bin/env python3
"""A TCP relay that adds latency: every byte it forwards, either way, leaves DELAY_MS after it
arrived, in order. The lossy-link test runs it between orsa's executive and robot because the
machine's kernel has no netem (`tc qdisc ... netem` is refused); the packet loss of that test is
real (nftables drops packets in the test's own network namespace), the latency is this relay's.

    slow_link.py --listen 127.0.0.1:7001 --to 127.0.0.1:7000 --delay-ms 25

Prints `ready` on stdout once it listens. Standard library only.
"""

import argparse
import asyncio
import sys


def endpoint(text):
    host, _, port = text.rpartition(":")
    if not host or not port.isdigit():
        raise argparse.ArgumentTypeError(f"{text!r}: expected HOST:PORT")
    return host, int(port)


async def pipe(reader, writer, delay_s):
    """Copies reader to writer, each chunk delay_s after it was read, keeping the order."""
    loop = asyncio.get_running_loop()
    queue = asyncio.Queue()

    async def read():
        while True:
            data = await reader.read(65536)
            await queue.put((loop.time() + delay_s, data))
            if not data:
                return

    async def write():
        while True:
            due, data = await queue.get()
            wait = due - loop.time()
            if wait > 0:
                await asyncio.sleep(wait)
            if not data:
                writer.close()
                return
            writer.write(data)
            await writer.drain()

    try:
        await asyncio.gather(read(), write())
    except (ConnectionError, OSError):
        writer.close()


async def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--listen", type=endpoint, required=True)
    parser.add_argument("--to", type=endpoint, required=True)
    parser.add_argument("--delay-ms", type=float, required=True)
    args = parser.parse_args()
    if not 0 <= args.delay_ms <= 10_000:
        parser.error(f"--delay-ms {args.delay_ms}: expected 0 to 10000")
    delay_s = args.delay_ms / 1000

    async def serve(client_reader, client_writer):
        try:
            server_reader, server_writer = await asyncio.open_connection(*args.to)
        except OSError as e:
            print(f"slow_link: cannot reach {args.to}: {e}", file=sys.stderr)
            client_writer.close()
            return
        await asyncio.gather(
            pipe(client_reader, server_writer, delay_s),
            pipe(server_reader, client_writer, delay_s),
        )

    server = await asyncio.start_server(serve, *args.listen)
    print("ready", flush=True)
    async with server:
        await server.serve_forever()


if __name__ == "__main__":
    try:
        asyncio.run(main())
    except KeyboardInterrupt:
        pass
